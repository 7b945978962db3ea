#!/usr/bin/python3
"""The walls between the rooms hold (tests/walls/CMakeLists.txt).

1. A probe that includes another room's public header builds (the control: the probe's set-up
   is right, so the next failure means the wall).
2. A probe that includes another room's private header does not: the compiler cannot find it
   (a CLI room's, and a core room's from a target that links netkf_core).
3. No source or header of the project's rooms climbs out of its folder with a relative include.

Usage: check_walls.py BUILD_DIR SOURCE_DIR
"""
import pathlib
import re
import subprocess
import sys


def build(build_dir, target):
    r = subprocess.run(["cmake", "--build", build_dir, "--target", target], capture_output=True, text=True)
    return r.returncode, r.stdout + r.stderr


def main():
    build_dir, source_dir = sys.argv[1], pathlib.Path(sys.argv[2])
    failures = []
    rc, out = build(build_dir, "netkf_wall_probe_public")
    if rc != 0:
        failures.append("a public header of another room did not build:\n" + out[-2000:])
    rc, out = build(build_dir, "netkf_wall_probe_private")
    if rc == 0:
        failures.append("another room's private header (domain_guard.hpp) was found: the wall is open")
    elif not re.search(r"domain_guard\.hpp: No such file", out):
        failures.append("the private probe failed for another reason than the wall:\n" + out[-2000:])
    rc, out = build(build_dir, "netkf_wall_probe_core_private")
    if rc == 0:
        failures.append("a core room's private header (link_detail.hpp) was found: the wall is open")
    elif not re.search(r"link_detail\.hpp: No such file", out):
        failures.append("the core private probe failed for another reason than the wall:\n" + out[-2000:])
    climbing = re.compile(r'#include\s+"\.\./')
    for room in ["cli", "core", "dds", "node_main", "plant_node", "sensor_node", "channel_emulator",
                 "estimator_node", "python/bindings"]:
        for path in sorted((source_dir / room).rglob("*")):
            if path.suffix in (".cpp", ".hpp", ".h") and climbing.search(path.read_text(errors="replace")):
                failures.append(f"{path.relative_to(source_dir)} includes a file by climbing out of its folder")
    for f in failures:
        print("FAIL:", f)
    print("walls: %d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
