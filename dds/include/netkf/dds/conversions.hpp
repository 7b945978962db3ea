#pragma once
// Wire <-> core conversions: the only place where wire types meet Eigen / core types.
// Every conversion from the wire validates: a wrong size or a non-finite number throws
// ConversionError (never crashes, never lets a NaN into the math).
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "netkf/dds/wire.hpp"
#include "netkf/filter/kalman_filter.hpp"
#include "netkf/fit/recent_loss_fit.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/loss_model.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/delivered.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_reply.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/records/truth.hpp"
#include "netkf/support/types.hpp"

namespace netkf::dds {

class ConversionError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Steady-clock time in nanoseconds (stamps for latency measurement; same clock in all
/// processes of one host).
std::int64_t steady_now_ns();

// ---- vectors and matrices ----
/// `what` names the field in error messages. expected_size < 0: any size.
Vector to_vector(const std::vector<double>& values, int expected_size, const char* what);
std::vector<double> to_wire(const Vector& v);
/// Row-major `values` of a rows x cols matrix.
Matrix to_matrix(const std::vector<double>& row_major, int rows, int cols, const char* what);
std::vector<double> to_wire_row_major(const Matrix& m);
/// True when every value is finite.
bool all_finite(const std::vector<double>& values);

// ---- measurements ----
wire::Measurement make_measurement(int sensor_id, std::uint64_t k, std::int64_t stamp_ns, const Vector& y);
/// Throws ConversionError on a non-finite value or (expected_size >= 0) a wrong size.
SensorSample to_sensor_sample(const wire::Measurement& m, int expected_size = -1);
/// Samples in one wire::MeasurementBatch at most (the bound in idl/netkf.idl).
inline constexpr std::size_t kMaxBatchSamples = 100;
/// `samples`, in their order, as batches of at most kMaxBatchSamples (none for no sample).
std::vector<wire::MeasurementBatch> make_measurement_batches(std::vector<wire::Measurement> samples);

// ---- plant ----
wire::Truth make_truth(std::uint64_t k, double t, const Vector& x, const Vector& applied_input,
                       bool input_arrived = true);
wire::Tick make_tick(std::uint64_t k, double t, const Vector& applied_input, bool final_tick);
/// The truth x_k checked against the state dimension (throws ConversionError).
Vector truth_state(const wire::Truth& truth, int state_dim);
/// The applied input u_{k-1} of a tick; empty vector when the tick carries none.
/// Throws ConversionError when present with a size other than input_dim or non-finite.
Vector tick_applied_input(const wire::Tick& tick, int input_dim);
wire::ControlInput make_control_input(std::uint64_t k, const Vector& u);
Vector control_input_u(const wire::ControlInput& c, int input_dim);
/// The truth as recorders keep it; ConversionError on a non-finite value.
Truth from_wire(const wire::Truth& truth);
/// A delivered measurement as recorders keep it; ConversionError on a non-finite value.
DeliveredMeasurement delivered_of(const wire::Measurement& measurement);

// ---- estimate ----
/// Throws ConversionError if x_hat / P are not finite or P is not square of x_hat's size
/// (the estimator never publishes NaN: this is the last gate).
wire::Estimate to_wire(const Estimate& e);
/// Validates sizes (state_dim < 0: taken from x_hat) and finiteness.
Estimate from_wire(const wire::Estimate& e, int state_dim = -1);
/// "ok" / "diverging" <-> FilterState; throws ConversionError on anything else.
FilterState filter_state_from_string(const std::string& s);

// ---- links ----
/// A whole link on the wire and back; from_wire validates (ConversionError naming the key).
wire::LinkSpec to_wire(const LinkSpec& link);
LinkSpec from_wire(const wire::LinkSpec& link);
/// A link change request: the keys to change.
wire::LinkControl make_link_control(std::uint64_t request_id, int sensor_id, const LinkKeys& keys);
/// The keys a request carries (names and values as sent; the channel validates them
/// against the link with apply_link_keys).
LinkKeys link_keys_of(const wire::LinkControl& control);
/// A link's status on the wire and back (stationary loss and theory burst from its link).
/// from_wire validates the link, the recent-samples fit and the relayed topic (ConversionError)
/// and clamps in_time into [0, 1].
wire::LinkStatus to_wire(const LinkStatus& status, std::int64_t stamp_ns);
LinkStatus from_wire(const wire::LinkStatus& status);
/// The recent samples' model a status carries; none before the link's first sample, and
/// ConversionError when it is malformed (unknown family, probabilities outside [0, 1], more
/// drops than samples).
std::optional<fit::RecentLossFit> recent_fit_of(const wire::LinkStatus& status);
/// The link a status describes (throws ConversionError when it is not a valid link).
LinkSpec link_of(const wire::LinkStatus& status);
/// The answer to one link change request.
wire::LinkControlReply to_wire(const LinkReply& reply);
LinkReply from_wire(const wire::LinkControlReply& reply);
/// One entry of the link journal (a failed timeline event is not published: change.failure is
/// not on the wire). from_wire validates the link, the origin and the relayed topic.
wire::LinkChange to_wire(const LinkChange& change, std::int64_t stamp_ns);
LinkChange from_wire(const wire::LinkChange& change);
/// The topic a relayed link's status or journal entry names ("" for a channel's link); throws
/// ConversionError when the link id is not that topic's (relay_topic_link_id).
std::string relayed_topic_of(int sensor_id, const std::string& topic);

}  // namespace netkf::dds
