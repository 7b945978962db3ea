# What a room may link (docs/architecture.md, "The CLI's rooms" and "Core's map"): DDS only in
# dds/, the node apps and the CLI rooms that talk to the network; CLI11 only in the commands
# room, the node mains and the executables; sockets (the dashboard's server) only in the rooms
# that serve a page. Checked when the build is configured, over each target's whole link
# closure (a library linked PUBLIC by a dependency counts): a target that breaks a rule stops
# the configuration, naming the chain. tests/walls/check_room_uses.py checks the same rules on
# the headers each object file actually included.

# The targets each rule protects and the libraries the rule refuses them.
set(NETKF_RULE_NO_DDS_TARGETS
  netkf_core netkf_sensor_logic netkf_channel_logic netkf_estimator_logic netkf_plant_logic
  netkf_cli_common netkf_cli_live netkf_cli_recording netkf_cli_theory netkf_cli_sweep
  netkf_cli_launch_logic netkf_cli_dashboard_protocol netkf_python_core)
set(NETKF_RULE_NO_DDS_REFUSED fastrtps fastcdr netkf_idl netkf_dds netkf_dds_conversions)
set(NETKF_RULE_NO_CLI11_TARGETS
  ${NETKF_RULE_NO_DDS_TARGETS} netkf_dds netkf_dds_conversions netkf_sensor_app netkf_channel_app
  netkf_estimator_app netkf_plant_app netkf_cli_live_bus netkf_cli_recording_cdr netkf_cli_dashboard
  netkf_cli_launch netkf_cli_relay)
set(NETKF_RULE_NO_CLI11_REFUSED CLI11::CLI11 netkf_node_main netkf_cli_commands)
set(NETKF_RULE_NO_SOCKETS_TARGETS
  ${NETKF_RULE_NO_DDS_TARGETS} netkf_dds netkf_dds_conversions netkf_sensor_app netkf_channel_app
  netkf_estimator_app netkf_plant_app netkf_node_main netkf_cli_live_bus netkf_cli_recording_cdr)
set(NETKF_RULE_NO_SOCKETS_REFUSED netkf_cli_dashboard)

# netkf_link_closure(<target> <out-var>): every library <target> links, directly or through
# others, as "lib<-via<-...<-target" chains keyed by library name (a list of "lib|chain").
function(netkf_link_closure target out)
  set(seen "")
  set(result "")
  set(queue "${target}|${target}")
  while(queue)
    list(POP_FRONT queue item)
    string(REPLACE "|" ";" parts "${item}")
    list(GET parts 0 name)
    list(GET parts 1 chain)
    if(name IN_LIST seen)
      continue()
    endif()
    list(APPEND seen ${name})
    if(NOT name STREQUAL target)
      list(APPEND result "${name}|${chain}")
    endif()
    if(NOT TARGET ${name})
      continue()
    endif()
    get_target_property(aliased ${name} ALIASED_TARGET)
    if(aliased)
      list(APPEND queue "${aliased}|${chain}")
      continue()
    endif()
    set(deps "")
    get_target_property(type ${name} TYPE)
    if(NOT type STREQUAL "INTERFACE_LIBRARY")
      get_target_property(direct ${name} LINK_LIBRARIES)
      if(direct)
        list(APPEND deps ${direct})
      endif()
    endif()
    get_target_property(iface ${name} INTERFACE_LINK_LIBRARIES)
    if(iface)
      list(APPEND deps ${iface})
    endif()
    foreach(dep IN LISTS deps)
      # $<LINK_ONLY:x> (a static library's private link) still links x.
      string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" dep "${dep}")
      if(dep MATCHES "^\\$<" OR dep MATCHES "^-")
        continue()
      endif()
      list(APPEND queue "${dep}|${dep} <- ${chain}")
    endforeach()
  endwhile()
  set(${out} "${result}" PARENT_SCOPE)
endfunction()

# netkf_check_room_rules(): apply the three rules to the targets this configuration has.
function(netkf_check_room_rules)
  set(broken "")
  foreach(rule IN ITEMS NO_DDS NO_CLI11 NO_SOCKETS)
    foreach(target IN LISTS NETKF_RULE_${rule}_TARGETS)
      if(NOT TARGET ${target})
        continue()
      endif()
      netkf_link_closure(${target} closure)
      foreach(entry IN LISTS closure)
        string(REPLACE "|" ";" parts "${entry}")
        list(GET parts 0 lib)
        list(GET parts 1 chain)
        if(lib IN_LIST NETKF_RULE_${rule}_REFUSED)
          list(APPEND broken "${rule}: ${target} links ${lib} (${chain})")
        endif()
      endforeach()
    endforeach()
  endforeach()
  if(broken)
    list(JOIN broken "\n  " text)
    message(FATAL_ERROR "A room links what docs/architecture.md forbids it:\n  ${text}")
  endif()
endfunction()
