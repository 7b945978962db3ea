#pragma once
// Umbrella header of the netkf DDS library (netkf_dds).
#include "netkf/dds/conversions.hpp"
#include "netkf/dds/endpoints.hpp"
#include "netkf/dds/participant.hpp"
#include "netkf/dds/topics.hpp"
#include "netkf/dds/wire.hpp"
#include "netkf/dds/node_support.hpp"
