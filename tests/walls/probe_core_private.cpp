// A core room's private header (core/src/links/link_detail.hpp): only the link's own sources
// see it. Built against netkf_core, which exports core/include only.
#include "link_detail.hpp"

int netkf_wall_probe_core_private() { return 0; }
