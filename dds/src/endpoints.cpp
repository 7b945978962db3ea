// Explicit instantiations of Writer/Reader for every wire type: compiled once here
// (endpoints.hpp declares them extern), which also checks the templates build.
#include "netkf/dds/endpoints.hpp"

namespace netkf::dds {
template class Writer<wire::Truth>;
template class Writer<wire::Tick>;
template class Writer<wire::Measurement>;
template class Writer<wire::MeasurementBatch>;
template class Writer<wire::Estimate>;
template class Writer<wire::ControlInput>;
template class Writer<wire::LinkControl>;
template class Writer<wire::LinkControlReply>;
template class Writer<wire::LinkStatus>;
template class Writer<wire::LinkChange>;
template class Writer<wire::Presence>;
template class Reader<wire::Truth>;
template class Reader<wire::Tick>;
template class Reader<wire::Measurement>;
template class Reader<wire::MeasurementBatch>;
template class Reader<wire::Estimate>;
template class Reader<wire::ControlInput>;
template class Reader<wire::LinkControl>;
template class Reader<wire::LinkControlReply>;
template class Reader<wire::LinkStatus>;
template class Reader<wire::LinkChange>;
template class Reader<wire::Presence>;
}  // namespace netkf::dds
