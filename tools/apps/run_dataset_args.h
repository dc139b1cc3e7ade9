#pragma once
/// \file run_dataset_args.h
/// dypho_run_dataset's command line: the options, the usage text and the parser.

#include <ostream>
#include <string>

#include "dypho/pipeline/realtime_runner.h"

namespace dypho::run_dataset {

/// The command line of dypho_run_dataset.
struct Args {
  std::string dataset;
  std::string out;
  std::string camera;
  std::string config;
  std::string mask = "flow";
  long max_frames = -1;
  bool eval = true;
  bool build_map = true;  ///< --no-map: mask and tracking only
  bool quiet = false;
  bool print_config = false;
  bool save_masks = false;
  bool realtime = false;                       ///< --realtime: frames at their stamps, live policy
  pipeline::RealtimeOptions realtime_options;  ///< --realtime-speed, --realtime-queue
  bool realtime_option_given = false;          ///< one of those was given (needs --realtime)
  int eval_every = 10;                         ///< --eval-every: map views scored (0: none)
  /// --resume: a previous run's --out (its session/ is loaded) or a session folder; empty = none
  std::string resume;
  bool localization_only = false;  ///< --localization-only: localise in the resumed map, change nothing
  /// --late-mask-poses: the mask gets each pose one frame late (PipelineOptions::mask_poses_one_frame_late)
  bool late_mask_poses = false;
};

/// The usage text.
void usage(std::ostream& os);

/// A whole-string number for option `key`; a clear error otherwise.
double parseNumber(const std::string& key, const std::string& text);

/// Parses the command line; throws std::runtime_error naming a wrong or missing option. -h and
/// --help print the usage and exit.
Args parseArgs(int argc, char** argv);

}  // namespace dypho::run_dataset
