// The ros2 MCAP profile with the real CDR codec (cli/recording/ros2_cdr_codec.hpp, Fast DDS's
// type support): `netkf trace extract`'s readers give the same delivered samples and input
// arrivals from a ros2-profile file as from a json-profile file of the same records, refuse a
// ros2 file without the codec, and name the file of a message that is not its type's CDR.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

#include "netkf/cli/recording/recording.hpp"
#include "netkf/cli/recording/ros2_cdr_codec.hpp"
#include "netkf/cli/recording/trace_extract.hpp"

namespace netkf::cli {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "netkf-ros2-bag-XXXXXX").string();
    path = mkdtemp(pattern.data());
  }
  ~TempDir() { fs::remove_all(path); }
};

/// The same records, a closed loop's truths (an input, arrived or not) and delivered samples,
/// in either profile, written as `netkf record --out FILE.mcap --samples FILE` writes them.
std::string record(const fs::path& path, McapOptions options) {
  const Scenario scenario = default_scenario();
  fs::path samples = path;
  samples += ".samples.csv";  // given: the MCAP file gets the delivered samples' channel
  Recording r(path.string(), samples.string(), scenario, std::move(options));
  for (std::int64_t k = 0; k < 12; ++k) {
    const bool arrived = k == 0 || k % 3 != 1;
    r.truth(Truth{k, static_cast<double>(k) * scenario.period_s(),
                        std::vector<double>(static_cast<std::size_t>(scenario.state_dim()), 0.25 * k), {-0.5 * k},
                        arrived});
    for (const auto& sensor : scenario.sensors)
      if ((k + sensor.id) % 4 != 0)
        r.delivered(DeliveredMeasurement{sensor.id, k, 66000.0 + 0.01 * k, std::vector<double>(1, 0.1 * k)});
  }
  r.finish();
  return path.string();
}

TEST(Ros2Bag, TraceExtractReadsBothProfilesAlike) {
  TempDir dir;
  const auto codec = ros2::make_fastcdr_codec();
  const std::string json = record(dir.path / "json.mcap", {});
  const std::string bag = record(dir.path / "ros2.mcap", McapOptions{McapProfile::ros2, codec, "ros2.mcap"});

  const auto want_samples = read_delivered_samples(json);
  const auto got_samples = read_delivered_samples(bag, codec.get());
  ASSERT_FALSE(want_samples.periods_by_sensor.empty());
  EXPECT_EQ(got_samples.periods_by_sensor, want_samples.periods_by_sensor);
  EXPECT_EQ(got_samples.first_k, want_samples.first_k);
  EXPECT_EQ(got_samples.last_k, want_samples.last_k);

  const auto want_inputs = read_input_arrivals(json);
  const auto got_inputs = read_input_arrivals(bag, codec.get());
  ASSERT_EQ(want_inputs.periods_by_sensor.count(kControlLinkId), 1u);
  EXPECT_EQ(got_inputs.periods_by_sensor, want_inputs.periods_by_sensor);
  EXPECT_EQ(got_inputs.last_k, 10);  // the input of period 10 arrived (or not) in period 11's truth

  const auto trace = extract_link_trace(got_samples, default_scenario().sensors[0].id);
  EXPECT_GT(trace.size(), 0u);
}

TEST(Ros2Bag, ARos2FileNeedsTheCodecAndItsMessagesMustBeTheirCdr) {
  TempDir dir;
  const auto codec = ros2::make_fastcdr_codec();
  const std::string bag = record(dir.path / "ros2.mcap", McapOptions{McapProfile::ros2, codec, "ros2.mcap"});
  try {
    read_delivered_samples(bag);  // no codec
    FAIL() << "a ros2 file was read without a CDR decoder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("CDR"), std::string::npos) << e.what();
  }
  // A delivered message whose encapsulation header is not CDR's: the file is named.
  std::ifstream in(bag, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  std::string data = bytes.str();
  const std::string topic = "/netkf/measurement/delivered";
  ASSERT_NE(data.find(topic), std::string::npos);
  // Every Message record's data starts after opcode(1) length(8) channel(2) seq(4) times(16).
  std::size_t pos = 8;
  bool damaged = false;
  while (pos + 9 < data.size() && !damaged) {
    const auto op = static_cast<unsigned char>(data[pos]);
    std::uint64_t len = 0;
    for (int i = 7; i >= 0; --i) len = (len << 8) | static_cast<unsigned char>(data[pos + 1 + i]);
    if (op == 0x05 && data[pos + 9] == 2) {  // channel 2: the delivered samples
      data[pos + 9 + 22] = 0x7f;  // representation identifier 0x7f01: unknown
      damaged = true;
    }
    pos += 9 + len;
  }
  ASSERT_TRUE(damaged);
  const fs::path bad = dir.path / "bad.mcap";
  std::ofstream(bad, std::ios::binary) << data;
  try {
    read_delivered_samples(bad.string(), codec.get());
    FAIL() << "a message that is not CDR was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.mcap"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("netkf_msgs/msg/Measurement"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace netkf::cli
