/// dypho_evaluate: ATE / RPE of an estimated TUM trajectory against ground truth.
///
///   dypho_evaluate --estimate FILE --groundtruth FILE [--bonn-correction] [--plot OUT.png]
///                  [--delta S]... [--max-gap S] [--json OUT.json] [--errors OUT.txt]
///                  [--title TEXT]

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli_number.h"
#include "dypho/common/atomic_file.h"
#include "dypho/tools/evaluation.h"
#include "dypho/common/trajectory_io.h"
#include "dypho/tools/trajectory_plot.h"

namespace {

struct Args {
  std::string estimate;
  std::string groundtruth;
  bool bonn_correction = false;
  std::string plot;
  std::string json;
  std::string errors;
  std::string title;
  std::vector<double> deltas_s;
  double max_gap_s = 0.1;
};

constexpr const char* kUsage =
    "usage: dypho_evaluate --estimate FILE --groundtruth FILE [options]\n"
    "  --estimate FILE      estimated trajectory, TUM format (timestamp tx ty tz qx qy qz qw)\n"
    "  --groundtruth FILE   ground truth, TUM format (e.g. the dataset's groundtruth.txt)\n"
    "  --bonn-correction    apply the Bonn RGB-D Dynamic marker->camera correction to the ground truth\n"
    "  --plot OUT.png       write a top-view plot of ground truth vs aligned estimate\n"
    "  --delta S            RPE time delta in seconds (repeatable; default 1.0)\n"
    "  --max-gap S          max ground-truth gap for interpolation and RPE pairing [s] (default 0.1)\n"
    "  --json OUT.json      write all numbers as JSON\n"
    "  --errors OUT.txt     write the ATE position error of every pose (\"stamp_s error_m\" per line)\n"
    "  --title TEXT         plot title (default: the estimate file name)\n";

double parsePositive(const std::string& flag, const std::string& value) {
  const std::optional<double> v = dypho::cli::wholeStringNumber(value);
  if (!v || !(*v > 0.0)) {
    throw std::invalid_argument(flag + " expects a positive number of seconds, got '" + value + "'");
  }
  return *v;
}

Args parseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "-h" || flag == "--help") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (flag == "--bonn-correction") {
      a.bonn_correction = true;
      continue;
    }
    if (i + 1 >= argc) throw std::invalid_argument("missing value after " + flag);
    const std::string value = argv[++i];
    if (flag == "--estimate")
      a.estimate = value;
    else if (flag == "--groundtruth")
      a.groundtruth = value;
    else if (flag == "--plot")
      a.plot = value;
    else if (flag == "--json")
      a.json = value;
    else if (flag == "--errors")
      a.errors = value;
    else if (flag == "--title")
      a.title = value;
    else if (flag == "--delta")
      a.deltas_s.push_back(parsePositive(flag, value));
    else if (flag == "--max-gap")
      a.max_gap_s = parsePositive(flag, value);
    else
      throw std::invalid_argument("unknown option '" + flag + "'");
  }
  if (a.estimate.empty()) throw std::invalid_argument("--estimate FILE is required");
  if (a.groundtruth.empty()) throw std::invalid_argument("--groundtruth FILE is required");
  if (a.deltas_s.empty()) a.deltas_s.push_back(1.0);
  if (a.title.empty()) a.title = a.estimate.substr(a.estimate.find_last_of('/') + 1);
  return a;
}

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

/// The RPE over one --delta: its result, or why there is none.
struct RpeOutcome {
  double delta_s;
  std::optional<dypho::tools::RpeResult> result;
  std::string error;
};

/// The numbers of one evaluation: both trajectories as read and every metric asked for.
struct Evaluation {
  std::vector<dypho::StampedPose> estimate;
  std::vector<dypho::StampedPose> groundtruth;  ///< with --bonn-correction applied
  dypho::tools::AteResult ate;                  ///< rigid alignment, no scale
  std::optional<dypho::tools::AteResult> ate_scaled;
  std::string scaled_error;      ///< why ate_scaled is missing
  std::vector<RpeOutcome> rpes;  ///< one per --delta, in order
};

/// Reads both trajectories and computes the ATE (rigid, and with scale when it can) and the RPE
/// over each delta.
Evaluation evaluate(const Args& args) {
  using namespace dypho;
  using namespace dypho::tools;
  Evaluation ev;
  ev.estimate = readTumTrajectory(args.estimate);
  ev.groundtruth = readTumTrajectory(args.groundtruth);
  if (args.bonn_correction) ev.groundtruth = applyBonnCorrection(ev.groundtruth);

  ev.ate = computeAte(ev.estimate, ev.groundtruth, args.max_gap_s);
  // With one scale as well (Sim(3)): not the benchmark's number, but it tells a scale error (a
  // depth sensor reading long or short) from the shape of the trajectory.
  try {
    ev.ate_scaled = computeAte(ev.estimate, ev.groundtruth, args.max_gap_s, AteAlignment::kWithScale);
  } catch (const std::runtime_error& e) {
    ev.scaled_error = e.what();
  }
  for (double d : args.deltas_s) {
    RpeOutcome o{d, std::nullopt, ""};
    try {
      o.result = computeRpe(ev.estimate, ev.groundtruth, d, args.max_gap_s);
    } catch (const std::runtime_error& e) {
      o.error = e.what();
    }
    ev.rpes.push_back(o);
  }
  return ev;
}

/// The results on stdout: inputs, ATE (rigid, then with scale) and one line per RPE delta.
void printEvaluation(const Args& args, const Evaluation& ev) {
  const dypho::tools::AteResult& ate = ev.ate;
  std::printf("estimate:     %s (%zu poses)\n", args.estimate.c_str(), ev.estimate.size());
  std::printf("ground truth: %s (%zu poses%s)\n", args.groundtruth.c_str(), ev.groundtruth.size(),
              args.bonn_correction ? ", Bonn correction applied" : "");
  std::printf("ATE (rigid alignment, no scale): %zu pairs\n", ate.num_pairs);
  std::printf("  rmse   %8.3f cm\n  mean   %8.3f cm\n  median %8.3f cm\n  max    %8.3f cm\n", ate.rmse_m * 100,
              ate.mean_m * 100, ate.median_m * 100, ate.max_m * 100);
  if (ev.ate_scaled) {
    std::printf("ATE with scale (Sim(3) alignment, for diagnosis): rmse %.3f cm, scale %.4f\n",
                ev.ate_scaled->rmse_m * 100, ev.ate_scaled->scale);
  } else {
    std::printf("ATE with scale: not available (%s)\n", ev.scaled_error.c_str());
  }
  for (const auto& o : ev.rpes) {
    if (o.result) {
      std::printf("RPE over %.3f s: %zu pairs, trans rmse %.3f cm, rot rmse %.3f deg\n", o.delta_s, o.result->num_pairs,
                  o.result->trans_rmse_m * 100, o.result->rot_rmse_deg);
    } else {
      std::printf("RPE over %.3f s: not available (%s)\n", o.delta_s, o.error.c_str());
    }
  }
}

/// --errors: the ATE position error of every pose, "stamp_s error_m" per line [s, m].
void writeAteErrors(const std::string& path, const dypho::tools::AteResult& ate) {
  dypho::writeFileAtomically(path, [&ate](std::ostream& out) {
    out << "# stamp_s ate_error_m (estimate rigidly aligned onto the ground truth)\n";
    out.precision(6);
    for (std::size_t i = 0; i < ate.stamps_s.size(); ++i) {
      out << std::fixed << ate.stamps_s[i] << ' ' << (ate.est_aligned_xyz[i] - ate.gt_xyz[i]).norm() << '\n';
    }
  });
}

/// The "rpe" array entry of one delta: its numbers, or its error.
void writeRpeJson(std::ostream& js, const RpeOutcome& o) {
  js << "    {\"delta_s\": " << o.delta_s;
  if (o.result) {
    js << ", \"num_pairs\": " << o.result->num_pairs << ", \"trans_rmse_m\": " << o.result->trans_rmse_m
       << ", \"rot_rmse_deg\": " << o.result->rot_rmse_deg << ", \"trans_mean_m\": " << o.result->trans_mean_m
       << ", \"rot_mean_deg\": " << o.result->rot_mean_deg << "}";
  } else {
    js << ", \"error\": " << jsonString(o.error) << "}";
  }
}

/// --json: every number of the evaluation as JSON (9 significant digits).
std::string evaluationJson(const Args& args, const Evaluation& ev) {
  const dypho::tools::AteResult& ate = ev.ate;
  std::ostringstream js;
  js.precision(9);
  js << "{\n  \"estimate\": " << jsonString(args.estimate) << ",\n  \"groundtruth\": " << jsonString(args.groundtruth)
     << ",\n  \"bonn_correction\": " << (args.bonn_correction ? "true" : "false")
     << ",\n  \"max_gap_s\": " << args.max_gap_s << ",\n  \"ate\": {\"num_pairs\": " << ate.num_pairs
     << ", \"rmse_m\": " << ate.rmse_m << ", \"mean_m\": " << ate.mean_m << ", \"median_m\": " << ate.median_m
     << ", \"max_m\": " << ate.max_m << ", \"std_m\": " << ate.std_m << "},\n  \"ate_with_scale\": ";
  if (ev.ate_scaled) {
    js << "{\"rmse_m\": " << ev.ate_scaled->rmse_m << ", \"scale\": " << ev.ate_scaled->scale << "}";
  } else {
    js << "{\"error\": " << jsonString(ev.scaled_error) << "}";
  }
  js << ",\n  \"rpe\": [";
  for (std::size_t i = 0; i < ev.rpes.size(); ++i) {
    js << (i ? ",\n" : "\n");
    writeRpeJson(js, ev.rpes[i]);
  }
  js << "\n  ]\n}\n";
  return js.str();
}

/// Writes what --plot, --errors and --json ask for, each followed by a line naming its file.
void writeRequestedFiles(const Args& args, const Evaluation& ev) {
  if (!args.plot.empty()) {
    dypho::tools::writeTrajectoryPlotPng(args.plot, ev.ate, args.title);
    std::printf("plot written to %s\n", args.plot.c_str());
  }
  if (!args.errors.empty()) {
    writeAteErrors(args.errors, ev.ate);
    std::printf("per-pose errors written to %s\n", args.errors.c_str());
  }
  if (!args.json.empty()) {
    const std::string js = evaluationJson(args, ev);
    dypho::writeFileAtomically(args.json, [&js](std::ostream& out) { out << js; });
    std::printf("json written to %s\n", args.json.c_str());
  }
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  try {
    args = parseArgs(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "dypho_evaluate: " << e.what() << "\n\n" << kUsage;
    return 2;
  }
  try {
    const Evaluation ev = evaluate(args);
    printEvaluation(args, ev);
    writeRequestedFiles(args, ev);
  } catch (const std::exception& e) {
    std::cerr << "dypho_evaluate: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
