# NumPy cross-checks of the theory toolkit (Debian python3-numpy), run by /usr/bin/python3
# against the `netkf` CLI (not built in the sanitizer tree, which builds the test programs only).
if(TARGET netkf AND NOT NETKF_SANITIZE)
  add_test(NAME validation_numpy_bounds
         COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/validation/numpy_bounds.py
                 $<TARGET_FILE:netkf> ${CMAKE_CURRENT_SOURCE_DIR}/data/theory)
  set_tests_properties(validation_numpy_bounds PROPERTIES LABELS validation TIMEOUT 300)
  netkf_test_slots(2 validation_numpy_bounds)
endif()
# `netkf analyze` answers for 512 sensors (theory beyond 16 sensors; closed form in Python).
if(TARGET netkf AND NOT NETKF_SANITIZE)
  add_test(NAME validation_cli_many_sensors
         COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/validation/cli_many_sensors.py $<TARGET_FILE:netkf>)
  set_tests_properties(validation_cli_many_sensors PROPERTIES LABELS validation TIMEOUT 300)
  netkf_test_slots(2 validation_cli_many_sensors)
endif()
