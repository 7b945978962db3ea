// The CSV recorders (record_csv.hpp): the period and sample files of `--record`, their headers
// and rows written out by hand here, in time and with fuse_within's revisions.
#include <gtest/gtest.h>

#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "record_csv.hpp"

namespace netkf::cli {
namespace {

TEST(PeriodCsv, ExactHeaderAndJoinedRows) {
  EXPECT_EQ(PeriodCsvRecorder::header(2), "k,t,x0,x1,xhat0,xhat1,trace_P,fused,late,state,late_samples");
  PeriodCsvRecorder r(2);
  Estimate e;
  e.k = 5;
  e.x_hat = Vector{{0.1, 1.0 / 3.0}};
  e.P = Matrix{{2.0, 0.25}, {0.25, 0.5}};  // Tr P = 2.5
  e.fused = {1, 3};
  e.late = 2;
  e.late_sensors = {1, 1};
  e.late_periods = {3, 4};
  r.add_estimate(e);
  std::ostringstream out;
  EXPECT_EQ(r.flush(out), 0u);  // no truth for k = 5 yet
  r.add_truth({5, 0.05, {1.0, -2.0}, {}});
  EXPECT_EQ(r.flush(out), 1u);
  EXPECT_EQ(out.str(), "5,0.050000000000000003,1,-2,0.10000000000000001,0.33333333333333331,2.5,1;3,2,ok,3:1;4:1\n");
  // 17 significant digits give back the exact double.
  EXPECT_EQ(std::strtod("0.33333333333333331", nullptr), 1.0 / 3.0);
  // Wrong sizes are counted, not written.
  r.add_truth({6, 0.06, {1.0}, {}});
  EXPECT_EQ(r.rejected(), 1u);
}

// Every period the plant ran has a row, in order: one whose estimate never came (the estimator
// was stopped, or the run ended first) is written with empty estimate cells and state `none`,
// and the rows after it wait for it (a file a reader can take as a time series) until an
// estimate of a later period says it will not come.
TEST(PeriodCsv, TruthWithoutEstimateIsARowInOrder) {
  PeriodCsvRecorder r(1);
  std::ostringstream out;
  auto estimate = [](std::uint64_t k, double x) {
    Estimate e;
    e.k = k;
    e.x_hat = Vector{{x}};
    e.P = Matrix{{1.0}};
    e.fused = {1};
    return e;
  };
  r.add_truth({0, 0.0, {1.0}, {}});
  r.add_estimate(estimate(0, 0.5));
  r.add_truth({1, 0.01, {2.0}, {}});  // its estimate never comes
  r.add_truth({2, 0.02, {3.0}, {}});
  EXPECT_EQ(r.flush(out), 1u);  // period 1 waits for its estimate
  r.add_truth({3, 0.03, {4.0}, {}});
  r.add_estimate(estimate(3, 3.5));  // a later period's: period 1's and 2's will not come
  EXPECT_EQ(r.flush(out), 3u);
  r.add_estimate(estimate(2, 2.5));  // too late: its row is written
  r.add_estimate(estimate(4, 9.0));  // no truth for 4 before the end: left out
  r.finish_pending();
  EXPECT_EQ(r.flush(out), 0u);
  EXPECT_EQ(out.str(), "0,0,1,0.5,1,1,0,ok,\n1,0.01,2,,,,,none,\n2,0.02,3,,,,,none,\n3,0.029999999999999999,4,3.5,1,1,0,ok,\n");
  EXPECT_EQ(r.rows_without_estimate(), 2u);
}

// An estimate that arrives after its period was written without one is not written again, and a
// period waits at most kGiveUpPeriods periods of truth for its estimate.
TEST(PeriodCsv, GivesUpOnAnEstimateAfterAWindowOfPeriods) {
  PeriodCsvRecorder r(1);
  std::ostringstream out;
  for (std::int64_t k = 0; k <= PeriodCsvRecorder::kGiveUpPeriods; ++k) r.add_truth({k, 0.01 * k, {1.0}, {}});
  EXPECT_EQ(r.flush(out), 1u);  // period 0, without its estimate
  Estimate e;
  e.k = 0;
  e.x_hat = Vector{{0.5}};
  e.P = Matrix{{1.0}};
  r.add_estimate(e);
  EXPECT_EQ(r.flush(out), 0u);
  EXPECT_EQ(out.str(), "0,0,1,,,,,none,\n");
}

// A closed loop's rows end with the input the plant applied to produce x_k.
TEST(PeriodCsv, ClosedLoopRowsCarryTheAppliedInput) {
  EXPECT_EQ(PeriodCsvRecorder::header(1, 0, 2), "k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u0,u1");
  EXPECT_EQ(PeriodCsvRecorder::header(1, 1, 1),
            "k,t,x0,xhat0,trace_P,fused,late,state,late_samples,revisions,xhat_final0,trace_P_final,fused_final,u0");
  PeriodCsvRecorder r(1, 0, 2);
  std::ostringstream out;
  r.add_truth({0, 0.0, {1.0}, {0.0, 0.0}});
  r.add_truth({1, 0.01, {2.0}, {-0.5, 0.25}});
  r.add_truth({2, 0.02, {2.0}, {1.0}});  // wrong input size: counted, not written
  Estimate e;
  e.k = 1;
  e.x_hat = Vector{{1.5}};
  e.P = Matrix{{1.0}};
  r.add_estimate(e);
  r.finish_pending();
  EXPECT_EQ(r.flush(out), 2u);
  EXPECT_EQ(out.str(), "0,0,1,,,,,none,,0,0\n1,0.01,2,1.5,1,,0,ok,,-0.5,0.25\n");
  EXPECT_EQ(r.rejected(), 1u);
  // A truth-only row of a fuse_within recording keeps every column.
  PeriodCsvRecorder f(1, 1, 1);
  f.add_truth({0, 0.0, {1.0}, {0.0}});
  f.finish_pending();
  std::ostringstream fout;
  f.flush(fout);
  EXPECT_EQ(fout.str(), "0,0,1,,,,,none,,,,,,0\n");
}

TEST(PeriodCsv, EmptyFusedSetIsAnEmptyCell) {
  PeriodCsvRecorder r(1);
  r.add_truth({0, 0.0, {1.0}, {}});
  Estimate e;
  e.k = 0;
  e.x_hat = Vector{{0.5}};
  e.P = Matrix{{1.0}};
  e.state = FilterState::diverging;
  r.add_estimate(e);
  std::ostringstream out;
  r.flush(out);
  EXPECT_EQ(out.str(), "0,0,1,0.5,1,,0,diverging,\n");
}

TEST(SampleCsv, MarksFusedAndUnfusedSamples) {
  EXPECT_EQ(SampleCsvRecorder::header(2), "k,sensor_id,stamp,fused,y0,y1");
  SampleCsvRecorder r(2);
  r.add_delivered({1, 7, 1.5, {0.25, 0.5}});
  r.add_delivered({2, 7, 1.5, {0.75}});
  Estimate e;
  e.k = 7;
  e.fused = {1};
  r.add_estimate(e);
  r.add_delivered({3, 7, 1.6, {1.0}});  // after the estimate: late, not fused
  std::ostringstream out;
  EXPECT_EQ(r.flush(out), 3u);
  EXPECT_EQ(out.str(), "7,1,1.5,1,0.25,0.5\n7,2,1.5,0,0.75,\n7,3,1.6000000000000001,0,1,\n");
}

Estimate revision_of(std::uint64_t k, std::uint32_t revision, double x, std::vector<int> fused) {
  Estimate e;
  e.k = k;
  e.revision = revision;
  e.x_hat = Vector{{x}};
  e.P = Matrix{{1.0}};
  e.fused = std::move(fused);
  return e;
}

// late_policy fuse_within, D = 1: a row keeps the in-time and the final estimate and waits
// until the in-time estimate of k + 2 is out; the last rows are written by finish_pending().
TEST(PeriodCsv, FuseWithinKeepsFirstAndFinalEstimate) {
  EXPECT_EQ(PeriodCsvRecorder::header(1, 1), "k,t,x0,xhat0,trace_P,fused,late,state,late_samples,revisions,xhat_final0,trace_P_final,fused_final");
  PeriodCsvRecorder r(1, 1);
  std::ostringstream out;
  r.add_truth({0, 0.0, {1.0}, {}});
  r.add_truth({1, 0.01, {2.0}, {}});
  r.add_estimate(revision_of(0, 0, 0.5, {1}));
  r.add_estimate(revision_of(0, 1, 0.75, {1, 2}));
  EXPECT_EQ(r.flush(out), 0u);  // k = 0 may still be revised
  r.add_estimate(revision_of(1, 0, 1.5, {}));
  EXPECT_EQ(r.flush(out), 0u);  // k = 0's window is open until k = 1's deadline
  r.add_estimate(revision_of(0, 2, 0.875, {1, 2, 3}));
  r.add_estimate(revision_of(2, 0, 9.0, {}));
  EXPECT_EQ(r.flush(out), 1u);
  r.finish_pending();
  EXPECT_EQ(r.flush(out), 1u);
  EXPECT_EQ(out.str(),
            "0,0,1,0.5,1,1,0,ok,,2,0.875,1,1;2;3\n"
            "1,0.01,2,1.5,1,,0,ok,,0,1.5,1,\n");
}

TEST(SampleCsv, FuseWithinMarksFinalAndInTimeFusion) {
  EXPECT_EQ(SampleCsvRecorder::header(1, 2), "k,sensor_id,stamp,fused,fused_in_time,y0");
  SampleCsvRecorder r(1, 2);
  std::ostringstream out;
  r.add_delivered({1, 0, 0.5, {0.25}});
  r.add_estimate(revision_of(0, 0, 0.0, {1}));
  r.add_delivered({2, 0, 0.5, {0.75}});  // late for the in-time estimate, fused in revision 1
  r.add_estimate(revision_of(0, 1, 0.0, {1, 2}));
  r.add_estimate(revision_of(1, 0, 0.0, {}));
  r.add_estimate(revision_of(2, 0, 0.0, {}));
  EXPECT_EQ(r.flush(out), 0u);  // k = 0 is final once the in-time estimate of k = 3 is out
  r.add_estimate(revision_of(3, 0, 0.0, {}));
  EXPECT_EQ(r.flush(out), 2u);
  EXPECT_EQ(out.str(), "0,1,0.5,1,1,0.25\n0,2,0.5,1,0,0.75\n");
  r.add_delivered({1, 2, 0.7, {1.0}});
  r.finish_pending();
  EXPECT_EQ(r.flush(out), 1u);
}

}  // namespace
}  // namespace netkf::cli
