#pragma once
// What a live command records, behind one facade: truth and estimates (a CSV, or an MCAP
// file when the name ends with .mcap), optionally every delivered sample, and the live link
// changes journaled as FILE.events.yaml (which `netkf launch --events` replays).
//
// Opening a file that cannot be written is the user's input error (CommandError, exit 2,
// before anything starts); the files are opened and written under the output files' policy
// (output_file.hpp: a regular file only; the journal written whole, renamed in place). A write that fails during the run (e.g. a full disk) never throws
// from the flush: the first one is kept as write_error(), the caller stops the run in order
// and ends with exit 1 naming it.
#include <cstdint>
#include <ostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "netkf/cli/common/output_file.hpp"
#include "netkf/cli/recording/ros2_bag.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/delivered.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/records/truth.hpp"

namespace netkf::cli {

class LiveModel;

/// True when `path` names an MCAP recording (ends with ".mcap", any case).
bool is_mcap_path(const std::string& path);

/// The profile of an MCAP recording and, for ros2, the CDR codec (which needs DDS: the
/// commands give ros2_cdr_codec.hpp's).
struct McapOptions {
  McapProfile profile = McapProfile::json;
  std::shared_ptr<const ros2::Ros2Codec> codec;
  std::string file_name;  // ros2: the bag metadata's file (the name as given)
};

class Recording {
 public:
  /// Throws CommandError (bad_usage) when a file cannot be opened. `mcap` (profile, codec)
  /// applies when periods_file is an MCAP file. `model`: the launch's live model, which the
  /// MCAP recorder reads (fed by the launch before each record reaches the recording; it must
  /// outlive the recording); none: the recorder keeps its own.
  Recording(const std::optional<std::string>& periods_file, const std::optional<std::string>& samples_file,
            const Scenario& scenario, McapOptions mcap = {}, LiveModel* model = nullptr);
  Recording(const Recording&) = delete;
  Recording& operator=(const Recording&) = delete;
  ~Recording();

  void truth(const Truth& t);
  void estimate(const Estimate& e);
  void delivered(const DeliveredMeasurement& d);
  void link_status(const LinkStatus& l);
  /// A live change (ctl, dashboard) with the period it applied from: journaled.
  void link_change(const LinkChange& c);

  /// The files a recording of `periods_file` and `samples_file` writes, with the options
  /// that named them (`periods_option`: "--record" or "--out"): for check_output_files and
  /// refuse_existing before it is made. The journal FILE.events.yaml is one of them.
  static std::vector<FileArg> outputs(const std::string& periods_option, const std::optional<std::string>& periods_file,
                                      const std::string& samples_option, const std::optional<std::string>& samples_file);

  /// The MCAP options of `--mcap-profile` (`profile`, none: json) for the recording
  /// `periods_file` named by `periods_option`; the codec is used by the ros2 profile. Throws
  /// CommandError (bad_usage) for a profile given without an MCAP recording, or an unknown one.
  static McapOptions mcap_options(const std::string& periods_option, const std::optional<std::string>& periods_file,
                                  const std::optional<std::string>& profile,
                                  std::shared_ptr<const ros2::Ros2Codec> codec);

  bool wants_samples() const;
  bool wants_link_status() const;
  bool journals_changes() const;

  /// Write what is buffered (whole records: a reader of a killed launch gets all but an MCAP
  /// footer). A failed write is kept in write_error(), never thrown.
  void flush();
  /// Complete the MCAP file (DataEnd, Footer, magic): on every stop, SIGINT/SIGTERM included.
  void finish();
  /// The first write that failed during the run ("writing run.csv: No space left on device").
  const std::optional<std::string>& write_error() const;
  /// CSV: rows written; MCAP: estimates (periods) written.
  std::uint64_t rows() const;

 private:
  struct Files;  // the recorders, their streams and the journal (recording.cpp)
  /// Rewrite the journal whole (it is small), so it is complete whenever the launch stops.
  bool write_events();
  void check(const std::ostream& out, const std::string& file, int saved_errno);

  std::unique_ptr<Files> f_;
};

}  // namespace netkf::cli
