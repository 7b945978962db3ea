"""Fault matrix: kill -9 of `netkf launch` itself (after a sensor was killed too, so a stale
Fast DDS shared-memory segment exists). Asserted: every child ends on its own (they die with
their parent), the killed launch's private files and the stale segment are removed by the
next launch, which runs normally, and nothing is left after it."""
import os
import signal

from e2e_common import (DATA, Launch, check, finish, last_period, launch_files_dirs, netkf_processes,
                        require_netns, stale_participant_markers, wait_for, workdir, zombie_shm_segments)

require_netns()
domain = int(os.environ["NETKF_DOMAIN"])
scenario = os.path.join(DATA, "kill.yaml")
out = workdir("fault-launcher")
with Launch(scenario, 60, out, extra=["--sensors-per-process", "1"]) as run:
    check(wait_for(lambda: last_period(run.record) >= 50, 60), "the run reaches period 50")
    check(wait_for(lambda: len(run.child_pids()) == 8, 20), "the launch lists its children and spares")
    children = run.child_pids()
    check(len(children) == 8, "six children (plant, channel, estimator, three sensors) and the channel's and the "
          "estimator's warm spares (%s)" % sorted(children))
    sensor = children.get("sensor_node[1]")
    if sensor:
        os.kill(sensor, signal.SIGKILL)  # leaves its shared-memory segment behind
        check(wait_for(lambda: "restarting sensor_node[1]" in run.output(), 10), "the sensor is restarted")
    launch_pid = run.proc.pid
    own_dirs = launch_files_dirs(launch_pid)
    check(len(own_dirs) == 1, "the launch keeps its files in one private directory (%s)" % own_dirs)
    os.kill(launch_pid, signal.SIGKILL)
    run.proc.wait()
    check(wait_for(lambda: not netkf_processes(domain), 15),
          "every child ends when the launch is killed (left: %s)" % netkf_processes(domain))
check(all(os.path.isdir(d) for d in own_dirs), "a launch killed with SIGKILL could not remove its files")
check(len(zombie_shm_segments()) >= 1, "the killed sensor and launch left stale shared-memory segments")
check(len(stale_participant_markers(domain)) >= 2,
      "the killed sensor and launch left their participant markers (%s)" % stale_participant_markers(domain))

out2 = workdir("fault-launcher-next")
with Launch(scenario, 3, out2) as nxt:
    rc = nxt.wait(60)
    log = nxt.output()
check(rc == 0, "the next launch runs normally (rc=%s)" % rc)
check("removed the files of a launch that is no longer running" in log, "the next launch says it removed the stale files")
check(not any(os.path.exists(d) for d in own_dirs), "the killed launch's directory is gone")
check("removed what killed processes of earlier runs left" in log,
      "the next launch removed the stale shared memory (fastdds shm clean) and participant markers")
check(not zombie_shm_segments(), "no stale shared-memory segment left")
check(not stale_participant_markers(domain), "no stale participant marker left")
check(wait_for(lambda: not netkf_processes(domain), 10), "no netkf process left running")
finish()
