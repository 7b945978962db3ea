// The launch's DDS-free pieces: its plan (which children, in which order, with which flags) and
// its verdict (how a run that ended is judged). The expectations are the documented contracts
// (README "Exit codes", docs/architecture.md "netkf launch"), written out by hand here.
#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <thread>

#include "launch_plan.hpp"
#include "outage_watch.hpp"
#include "run_verdict.hpp"

namespace netkf::cli {
namespace {

LaunchPlanInputs inputs(std::vector<int> sensors, int per_process = 1) {
  LaunchPlanInputs in;
  in.scenario_file = "/run/x/scenario.yaml";
  in.checkpoint_file = "/run/x/estimator-checkpoint.json";
  in.domain = 42;
  in.run_id = 7;
  in.roles.sensor_ids = std::move(sensors);
  in.sensors_per_process = per_process;
  return in;
}

std::vector<std::string> names(const LaunchPlan& plan) {
  std::vector<std::string> out;
  for (const auto& c : plan.children) out.push_back(c.spec.name);
  return out;
}

/// The value after `flag` in `args` ("" when absent).
std::string value_of(const std::vector<std::string>& args, const std::string& flag) {
  const auto it = std::find(args.begin(), args.end(), flag);
  return it == args.end() || it + 1 == args.end() ? std::string() : *(it + 1);
}

bool has(const std::vector<std::string>& args, const std::string& flag) {
  return std::find(args.begin(), args.end(), flag) != args.end();
}

std::string identity(const std::string& name) { return name; }

TEST(LaunchPlan, ConsumersStartFirstAndThePlantLast) {
  const auto plan = plan_launch(inputs({1, 2, 3}), identity);
  EXPECT_EQ(names(plan), (std::vector<std::string>{"channel_emulator", "estimator_node", "sensor_node[1]",
                                                   "sensor_node[2]", "sensor_node[3]", "plant_node"}));
  for (const auto& c : plan.children) {
    EXPECT_EQ(c.spec.critical, c.spec.name == "plant_node") << c.spec.name;  // only the clock is never restarted
    EXPECT_EQ(c.estimator, c.spec.name == "estimator_node") << c.spec.name;
  }
  EXPECT_EQ(plan.children.back().spec.executable, "plant_node");
}

TEST(LaunchPlan, EveryChildReadsTheSameScenarioDomainAndRun) {
  const auto plan = plan_launch(inputs({1, 2}), identity);
  for (const auto& c : plan.children) {
    EXPECT_EQ(value_of(c.spec.args, "--scenario"), "/run/x/scenario.yaml") << c.spec.name;
    EXPECT_EQ(value_of(c.spec.args, "--domain"), "42") << c.spec.name;
    EXPECT_EQ(value_of(c.spec.args, "--run-id"), "7") << c.spec.name;
    EXPECT_EQ(value_of(c.spec.args, "--log-level"), "warn") << c.spec.name;
    // Not asked for: none of the optional network flags.
    EXPECT_FALSE(has(c.spec.args, "--discovery-server") || has(c.spec.args, "--dds-profile") ||
                 has(c.spec.args, "--secure"))
        << c.spec.name;
  }
}

TEST(LaunchPlan, OptionalNetworkFlagsReachEveryChild) {
  auto in = inputs({1});
  in.discovery_server = "10.0.0.1:11811";
  in.dds_profile = "p.xml";
  in.secure_dir = "/etc/netkf/secure";
  for (const auto& c : plan_launch(in, identity).children) {
    EXPECT_EQ(value_of(c.spec.args, "--discovery-server"), "10.0.0.1:11811") << c.spec.name;
    EXPECT_EQ(value_of(c.spec.args, "--dds-profile"), "p.xml") << c.spec.name;
    EXPECT_EQ(value_of(c.spec.args, "--secure"), "/etc/netkf/secure") << c.spec.name;
  }
}

// --standby: a second estimator, weaker, with the same checkpoint; the plant waits for both to
// read its ticks; every later estimator (a restart) is weaker than all before it.
TEST(LaunchPlan, AStandbyEstimatorIsWeakerAndThePlantWaitsForBoth) {
  auto in = inputs({1, 2});
  in.estimator_standby = true;
  const auto plan = plan_launch(in, identity);
  EXPECT_EQ(names(plan), (std::vector<std::string>{"channel_emulator", "estimator_node", "estimator_node[standby]",
                                                   "sensor_node[1]", "sensor_node[2]", "plant_node"}));
  const auto& primary = plan.children[1].spec;
  const auto& standby = plan.children[2].spec;
  EXPECT_TRUE(plan.children[1].estimator && plan.children[2].estimator);
  EXPECT_EQ(value_of(primary.args, "--ownership-strength"), std::to_string(estimator_ownership_strength(0)));
  EXPECT_EQ(value_of(standby.args, "--ownership-strength"), std::to_string(estimator_ownership_strength(1)));
  EXPECT_EQ(value_of(standby.args, "--resume-from"), "/run/x/estimator-checkpoint.json");
  EXPECT_EQ(value_of(plan.children.back().spec.args, "--tick-readers"), "2");
  EXPECT_FALSE(has(plan_launch(inputs({1, 2}), identity).children.back().spec.args, "--tick-readers"));
  for (int g = 0; g < 10; ++g) EXPECT_GT(estimator_ownership_strength(g), estimator_ownership_strength(g + 1));
  auto args = primary.args;
  set_ownership_strength(args, 17);
  EXPECT_EQ(value_of(args, "--ownership-strength"), "17");
}

TEST(LaunchPlan, WithoutAStandbyEachNewEstimatorOutranksTheDeadOne) {
  // A reader drops a newcomer's samples until the dead owner's lease expires unless the newcomer
  // is stronger (a tie goes by GUID): the warm spare must outrank the estimator it replaces.
  auto in = inputs({1, 2});
  in.warm_spares = true;
  const auto plan = plan_launch(in, identity);
  const auto& estimator = plan.children[1].spec;
  ASSERT_EQ(estimator.name, "estimator_node");
  ASSERT_TRUE(estimator.warm_spare);
  EXPECT_EQ(value_of(estimator.args, "--ownership-strength"), std::to_string(replacing_estimator_strength(0)));
  EXPECT_EQ(value_of(estimator.spare_args, "--ownership-strength"),
            std::to_string(replacing_estimator_spare_strength(0)));
  // the spare's argv is the child's but for the strength
  auto same = estimator.spare_args;
  set_ownership_strength(same, replacing_estimator_strength(0));
  EXPECT_EQ(same, estimator.args);
  EXPECT_EQ(replacing_estimator_strength(0), estimator_ownership_strength(0));
  // Life g is a fresh process (replacing_estimator_strength(g)) or the spare started during life
  // g - 1 (replacing_estimator_spare_strength(g - 1)); either outranks either kind of life g - 1.
  for (int g = 1; g < 10; ++g) {
    const std::uint32_t fresh = replacing_estimator_strength(g), spare = replacing_estimator_spare_strength(g - 1);
    const std::uint32_t before_fresh = replacing_estimator_strength(g - 1);
    const std::uint32_t before_spare = g >= 2 ? replacing_estimator_spare_strength(g - 2) : before_fresh;
    for (std::uint32_t now : {fresh, spare})
      for (std::uint32_t before : {before_fresh, before_spare}) EXPECT_GT(now, before) << "life " << g;
  }
  // With a standby there is no spare of the estimator: the standby covers a death.
  in.estimator_standby = true;
  EXPECT_FALSE(plan_launch(in, identity).children[1].spec.warm_spare);
}

TEST(LaunchPlan, OnlyTheEstimatorResumesFromTheCheckpoint) {
  for (const auto& c : plan_launch(inputs({1, 2}), identity).children)
    EXPECT_EQ(value_of(c.spec.args, "--resume-from"),
              c.spec.name == "estimator_node" ? "/run/x/estimator-checkpoint.json" : "")
        << c.spec.name;
}

TEST(LaunchPlan, ThePlantWaitsForPresenceAndCountsThisHostsTruthReaders) {
  auto in = inputs({1, 2, 3, 4, 5}, 2);
  in.ready_timeout_s = 12.5;
  const auto plan = plan_launch(in, identity);
  ASSERT_EQ(plan.sensor_groups, (std::vector<std::vector<int>>{{1, 2}, {3, 4}, {5}}));
  const auto& plant = plan.children.back().spec.args;
  EXPECT_TRUE(has(plant, "--wait-for-presence"));
  EXPECT_EQ(value_of(plant, "--truth-readers"), "4");  // 3 sensor processes and the launch
  EXPECT_EQ(value_of(plant, "--startup-wait-ms"), "12500");
  // Each sensor process gets its sensors' ids, in order.
  const auto& grouped = plan.children[2].spec;
  EXPECT_EQ(grouped.name, "sensor_node[1,2]");
  std::vector<std::string> ids;
  for (std::size_t i = 0; i + 1 < grouped.args.size(); ++i)
    if (grouped.args[i] == "--sensor-id") ids.push_back(grouped.args[i + 1]);
  EXPECT_EQ(ids, (std::vector<std::string>{"1", "2"}));
}

// Period 0 must reach every reader: the channel says it is present once the readers of the
// delivered samples on this host matched (the estimators, the launch's recorder when it records
// samples), a sensor process once the channel's reader matched.
TEST(LaunchPlan, TheChannelAndTheSensorsWaitForTheirReadersOnThisHost) {
  auto in = inputs({1, 2});
  EXPECT_EQ(value_of(plan_launch(in, identity).children.front().spec.args, "--delivered-readers"), "1");
  in.records_samples = true;
  EXPECT_EQ(value_of(plan_launch(in, identity).children.front().spec.args, "--delivered-readers"), "2");
  in.estimator_standby = true;
  const auto plan = plan_launch(in, identity);
  EXPECT_EQ(value_of(plan.children.front().spec.args, "--delivered-readers"), "3");
  for (const auto& c : plan.children)
    EXPECT_EQ(value_of(c.spec.args, "--raw-readers"), c.spec.name.rfind("sensor_node", 0) == 0 ? "1" : "") << c.spec.name;
  // The estimator on another host, no recorder here: present at once (nothing here to wait for).
  in.records_samples = false;
  in.roles = parse_launch_roles("sensors=1,channel", {1, 2});
  const auto partial = plan_launch(in, identity);
  const auto& channel = partial.children.front().spec;
  ASSERT_EQ(channel.name, "channel_emulator");
  EXPECT_FALSE(has(channel.args, "--delivered-readers"));
  // The channel on another host: the sensors say they are present at once.
  in.roles = parse_launch_roles("sensors=1", {1, 2});
  const auto sensors_only = plan_launch(in, identity);
  ASSERT_EQ(names(sensors_only), (std::vector<std::string>{"sensor_node[1]"}));
  EXPECT_FALSE(has(sensors_only.children.front().spec.args, "--raw-readers"));
}

TEST(LaunchPlan, APartialLaunchStartsOnlyItsRoles) {
  auto in = inputs({});
  in.roles = parse_launch_roles("sensors=1,3,channel", {1, 2, 3});
  const auto plan = plan_launch(in, identity);
  EXPECT_EQ(names(plan), (std::vector<std::string>{"channel_emulator", "sensor_node[1]", "sensor_node[3]"}));
}

TEST(LaunchPlan, SensorNiceAppliesToSensorProcessesOnly) {
  auto in = inputs({1});
  in.sensor_nice = 5;
  for (const auto& c : plan_launch(in, identity).children)
    EXPECT_EQ(c.spec.nice, c.spec.name == "sensor_node[1]" ? 5 : 0) << c.spec.name;
}

TEST(LaunchPlan, SensorsAreGroupedInScenarioOrder) {
  EXPECT_EQ(sensor_process_groups({4, 2, 9}, 1), (std::vector<std::vector<int>>{{4}, {2}, {9}}));
  EXPECT_EQ(sensor_process_groups({1, 2, 3, 4, 5}, 2), (std::vector<std::vector<int>>{{1, 2}, {3, 4}, {5}}));
  EXPECT_EQ(sensor_process_groups({1, 2, 3}, 8), (std::vector<std::vector<int>>{{1, 2, 3}}));
  EXPECT_TRUE(sensor_process_groups({}, 3).empty());
  EXPECT_THROW(sensor_process_groups({1}, 0), std::invalid_argument);
  EXPECT_EQ(sensor_process_name({7}), "sensor_node[7]");
  EXPECT_EQ(sensor_process_name({1, 2}), "sensor_node[1,2]");
  EXPECT_EQ(sensor_process_name({1, 2, 3}), "sensor_node[1-3]");
  EXPECT_EQ(sensor_process_name({1, 2, 3, 4, 6, 8, 9, 11, 12, 13}), "sensor_node[1-4,6,8,9,11-13]");
}

TEST(LaunchPlan, OnlyParsesRolesAndSensorLists) {
  const std::vector<int> ids{1, 3, 5};
  auto all = parse_launch_roles("all", ids);
  EXPECT_TRUE(all.all && all.plant && all.channel && all.estimator);
  EXPECT_EQ(all.sensor_ids, ids);
  auto a = parse_launch_roles("plant,sensors", ids);
  EXPECT_TRUE(a.plant && !a.channel && !a.estimator && !a.all);
  EXPECT_EQ(a.sensor_ids, ids);
  auto some = parse_launch_roles("sensors=5,1,channel", ids);
  EXPECT_EQ(some.sensor_ids, (std::vector<int>{1, 5}));  // in scenario order
  EXPECT_TRUE(some.channel && !some.plant);
  EXPECT_EQ(describe_launch_roles(some), "sensors 1,5, channel");
  EXPECT_EQ(describe_launch_roles(parse_launch_roles("estimator", ids)), "estimator");
  EXPECT_TRUE(parse_launch_roles("plant,sensors,channel,estimator", ids).all);
  EXPECT_FALSE(parse_launch_roles("plant,sensors=1,3,channel,estimator", ids).all);
  auto error_of = [&](const std::string& text) {
    try {
      parse_launch_roles(text, ids);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error_of("plant,sensor").find("unknown role 'sensor'"), std::string::npos);
  EXPECT_NE(error_of("sensors=2").find("no sensor 2"), std::string::npos);
  EXPECT_NE(error_of("plant,3").find("unknown role '3'"), std::string::npos);  // an id needs sensors= before it
  EXPECT_NE(error_of("").find("unknown role ''"), std::string::npos);
  EXPECT_NE(error_of("sensors=1,x").find("unknown role 'x'"), std::string::npos);
}

TEST(LaunchPlan, HostsDeriveTheSameRunIdFromScenarioAndDomain) {
  EXPECT_EQ(derived_run_id(42, 7), derived_run_id(42, 7));
  EXPECT_NE(derived_run_id(42, 7), derived_run_id(43, 7));
  EXPECT_NE(derived_run_id(42, 7), derived_run_id(42, 8));
  EXPECT_NE(derived_run_id(0, 0), 0u);
}

TEST(SensorGroups, AutoKeepsAtMostTwoSensorProcessesPerCpu) {
  // One process per sensor up to 2 x CPUs sensors.
  EXPECT_EQ(auto_sensors_per_process(0, 2), 1);
  EXPECT_EQ(auto_sensors_per_process(3, 2), 1);
  EXPECT_EQ(auto_sensors_per_process(4, 2), 1);
  EXPECT_EQ(auto_sensors_per_process(8, 4), 1);
  // Beyond that, the fewest per process that keep ceil(d / K) <= 2 x CPUs.
  for (unsigned cpus : {1u, 2u, 3u, 8u}) {
    for (std::size_t d = 1; d <= 300; ++d) {
      const int k = auto_sensors_per_process(d, cpus);
      std::vector<int> ids(d);
      for (std::size_t i = 0; i < d; ++i) ids[i] = static_cast<int>(i + 1);
      const auto groups = sensor_process_groups(ids, k);
      EXPECT_LE(groups.size(), 2 * cpus) << d << " sensors, " << cpus << " CPUs";
      if (k > 1) {
        EXPECT_GT(sensor_process_groups(ids, k - 1).size(), 2 * cpus) << d << " sensors, " << cpus << " CPUs";
      }
    }
  }
  EXPECT_EQ(auto_sensors_per_process(8, 2), 2);
  EXPECT_EQ(auto_sensors_per_process(64, 2), 16);
  EXPECT_EQ(auto_sensors_per_process(5, 0), 3);  // an unknown CPU count counts as one
  EXPECT_GE(usable_cpus(), 1u);
}

// ---------------------------------------------------------------- verdict

RunFacts ran(RunEnd end, std::uint64_t estimates, std::uint64_t fused) {
  RunFacts f;
  f.end = end;
  f.estimates = estimates;
  f.fused_periods = fused;
  f.ran_for_s = 30;
  return f;
}

TEST(RunVerdict, ARunThatFusedEndsOkWithItsEnd) {
  const auto v = judge_run(ran(RunEnd::duration, 300, 290));
  EXPECT_EQ(v.exit, ExitCode::ok);
  EXPECT_FALSE(v.failure);
  EXPECT_EQ(v.summary_end, "duration reached");
  auto finished = ran(RunEnd::finished, 300, 290);
  finished.finished_why = "the plant (pid 1 on a) ended the run";
  EXPECT_EQ(judge_run(finished).summary_end, "the plant (pid 1 on a) ended the run");
}

TEST(RunVerdict, AFailedProcessOrRecordingKeepsItsReason) {
  auto f = ran(RunEnd::process_failed, 0, 0);
  f.failure = "plant_node died";
  auto v = judge_run(f);
  EXPECT_EQ(v.exit, ExitCode::run_failed);
  EXPECT_EQ(v.failure, "plant_node died");
  EXPECT_EQ(v.summary_end, "failure: plant_node died");
  f.end = RunEnd::recording_failed;
  f.failure = "writing run.csv failed: No space left on device";
  v = judge_run(f);
  EXPECT_EQ(v.exit, ExitCode::run_failed);
  EXPECT_EQ(v.summary_end, "failure: writing run.csv failed: No space left on device");
}

TEST(RunVerdict, ARunWithoutEstimatesOrWithSilentSensorsIsIncomplete) {
  auto f = ran(RunEnd::signal, 0, 0);
  EXPECT_EQ(judge_run(f).failure, "no estimate arrived during the run (30.0 s): the network never got ready");
  f.end = RunEnd::duration;
  f.ran_for_s = 0.3;  // however short: a run that never got ready is no run of the scenario
  EXPECT_EQ(judge_run(f).failure, "no estimate arrived during the run (0.3 s): the network never got ready");
  EXPECT_EQ(judge_run(f).exit, ExitCode::run_failed);

  f = ran(RunEnd::duration, 10, 10);
  f.silent_sensors = {2, 5};
  EXPECT_EQ(judge_run(f).failure, "sensors 2, 5 never sent a sample to the channel: the run did not include them");
  f.estimates = 9;  // too early to judge
  EXPECT_FALSE(judge_run(f).failure);
}

// A closed loop that left plant.state_bound fails the run, naming what stalled before it,
// unless the run was started to show it (--allow-divergence); a failure of a process wins.
TEST(RunVerdict, ADivergedClosedLoopFailsUnlessAllowed) {
  auto f = ran(RunEnd::finished, 500, 480);
  f.finished_why = "plant_node finished";
  f.diverged = "the closed loop diverged at period 500: |x|_inf = 2e+08 exceeds plant.state_bound = 1e+08";
  f.outages_before = "estimator_node was stopped (SIGSTOP) for 3.0 s";
  auto v = judge_run(f);
  EXPECT_EQ(v.exit, ExitCode::run_failed);
  EXPECT_EQ(v.failure, *f.diverged + "; before it: estimator_node was stopped (SIGSTOP) for 3.0 s");
  f.outages_before.clear();
  EXPECT_EQ(judge_run(f).failure, *f.diverged + "; no process of the loop stalled before it");
  f.allow_divergence = true;
  v = judge_run(f);
  EXPECT_EQ(v.exit, ExitCode::ok);
  EXPECT_EQ(v.summary_end, *f.diverged + "; no process of the loop stalled before it (allowed)");
  f.allow_divergence = false;
  f.end = RunEnd::process_failed;
  f.failure = "estimator_node killed by signal 9 (no restarts left)";
  EXPECT_EQ(judge_run(f).failure, f.failure);
}

TEST(RunVerdict, NothingFusedIsAFailureUnlessEveryLinkDropsEverything) {
  auto f = ran(RunEnd::duration, 100, 0);
  EXPECT_EQ(judge_run(f).failure,
            "no sample was fused in 100 periods although the links deliver: the estimator never heard the channel");
  f.all_links_drop_everything = true;
  EXPECT_FALSE(judge_run(f).failure);
  f = ran(RunEnd::duration, 99, 0);
  EXPECT_FALSE(judge_run(f).failure);
}

TEST(RunVerdict, SnapshotFactsFindSilentSensorsAndLinksThatDeliver) {
  LiveSnapshot s;
  s.estimates = 12;
  LinkView a, b;
  a.sensor_id = 1;
  a.samples_total = 10;
  a.link.loss = BernoulliLink{1.0};
  b.sensor_id = 2;
  b.link.loss = BernoulliLink{1.0};
  s.links = {a, b};
  RunFacts f;
  add_snapshot_facts(s, f);
  EXPECT_EQ(f.estimates, 12u);
  EXPECT_EQ(f.silent_sensors, std::vector<int>{2});
  EXPECT_TRUE(f.all_links_drop_everything);
  s.links[1].link.loss = BernoulliLink{0.999};
  add_snapshot_facts(s, f);
  EXPECT_FALSE(f.all_links_drop_everything);
}

TEST(RunVerdict, FailedChecksFailTheRunAndTheSummarySaysHowItEnded) {
  RunSummary summary;  // nothing measured: a check on rms_error fails, saying why
  std::vector<Check> checks{parse_check("rms_error<0.8", {1})};
  RunVerdict v = judge_run(ran(RunEnd::duration, 300, 290));
  std::ostringstream table, json;
  conclude_run(summary, checks, "default", table, &json, "s.json", v);
  EXPECT_EQ(v.exit, ExitCode::run_failed);
  EXPECT_EQ(v.failure, "1 of 1 checks failed");
  EXPECT_NE(table.str().find("rms_error"), std::string::npos);
  EXPECT_NE(json.str().find("\"end\": \"duration reached\""), std::string::npos);
  EXPECT_NE(json.str().find("\"scenario\": \"default\""), std::string::npos);
}

TEST(RunVerdict, ARunThatFailedKeepsItsOwnFailureOverItsChecks) {
  auto f = ran(RunEnd::process_failed, 0, 0);
  f.failure = "channel_emulator gave up";
  RunVerdict v = judge_run(f);
  std::ostringstream table;
  conclude_run(RunSummary{}, {parse_check("rms_error<0.8", {1})}, "default", table, nullptr, "", v);
  EXPECT_EQ(v.failure, "channel_emulator gave up");
  EXPECT_EQ(v.exit, ExitCode::run_failed);
}

// The outages a diverged run is explained by, from what the launch sees.
using WatchClock = OutageWatch::Clock;

TEST(OutageWatch, AStoppedChildIsSeenInProc) {
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    for (;;) pause();
  }
  OutageWatch w(std::chrono::milliseconds(10));
  const auto t0 = WatchClock::now();
  using State = OutageWatch::ChildState;
  w.child("estimator_node", child, State::running, t0);
  EXPECT_TRUE(w.outages().empty());
  kill(child, SIGSTOP);
  for (int i = 0; i < 100 && process_state(child) != 'T'; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(process_state(child), 'T');
  w.child("estimator_node", child, State::running, t0 + std::chrono::milliseconds(100));
  kill(child, SIGCONT);
  for (int i = 0; i < 100 && process_state(child) == 'T'; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  w.child("estimator_node", child, State::running, t0 + std::chrono::milliseconds(3100));
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  EXPECT_FALSE(process_state(child));
  // Dead and waiting for its restart, then back.
  w.child("estimator_node", -1, State::restarting, t0 + std::chrono::milliseconds(4000));
  w.child("estimator_node", 1, State::running, t0 + std::chrono::milliseconds(4500));
  w.child("plant_node", -1, State::ended, t0 + std::chrono::milliseconds(4600));  // the run's end: no outage
  w.finish(t0 + std::chrono::milliseconds(5000));
  ASSERT_EQ(w.outages().size(), 2u);
  EXPECT_EQ(w.outages()[0].describe(), "estimator_node was stopped (SIGSTOP) for 3.0 s");
  EXPECT_EQ(w.outages()[1].describe(), "estimator_node was down (waiting for its restart) for 0.5 s");
  EXPECT_EQ(w.describe_between(t0 + std::chrono::milliseconds(4200), t0 + std::chrono::milliseconds(5000)),
            "estimator_node was down (waiting for its restart) for 0.5 s");
}

TEST(OutageWatch, GapsInTheDataNameThePartOfTheLoopThatStalled) {
  OutageWatch w(std::chrono::milliseconds(10));
  const auto t0 = WatchClock::now();
  auto at = [&](std::int64_t k) { return t0 + std::chrono::milliseconds(10 * k); };
  // Periods 0..99 normal; the estimator falls 60 periods behind from 100, catches up at 160;
  // then nothing is fused from 200 to 269; the plant publishes nothing for 2 s after 300.
  for (std::int64_t k = 0; k <= 400; ++k) {
    const auto now = k <= 300 ? at(k) : at(k) + std::chrono::seconds(2);
    w.truth(k, now);
    if (k < 100 || k >= 160) {
      if (k == 160)
        for (std::int64_t late = 100; late < 160; ++late) w.estimate(late, 1, now);
      w.estimate(k, (k >= 200 && k < 270) ? 0 : 2, now);
    }
  }
  w.finish(at(400) + std::chrono::seconds(2));
  std::vector<std::string> seen;
  for (const auto& o : w.outages()) seen.push_back(o.describe());
  ASSERT_EQ(seen.size(), 3u) << ::testing::PrintToString(seen);
  EXPECT_EQ(seen[0], "no estimate arrived (the estimator fell behind the plant) for 0.5 s (periods 100-159)");
  EXPECT_EQ(seen[1],
            "no sample reached the estimator (the channel emulator or every sensor stalled, or every link dropped) "
            "for 0.7 s (periods 200-269)");
  EXPECT_EQ(seen[2], "the plant published no period after period 300 for 2.0 s");
}

}  // namespace
}  // namespace netkf::cli
