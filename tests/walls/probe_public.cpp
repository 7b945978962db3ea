// Another room's public header: `commands` may use the launch's face.
#include "netkf/cli/launch/launch.hpp"

int netkf_wall_probe_public() { return 0; }
