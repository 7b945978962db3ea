#pragma once
// The generated wire types (idl/netkf.idl, compiled by fastddsgen into the build tree).
#include <netkf/wire/netkf.h>
#include <netkf/wire/netkfPubSubTypes.h>
