/// dypho_run_dataset: runs the mask, tracking and mapping cores in one process (no ROS master) on
/// a TUM-layout folder or a bag, as fast as possible, and writes the trajectory, timing and map.
/// With --realtime the frames arrive at their stamps instead and the live policy is used
/// (realtime_runner.h): what the graph would get on this machine.
///
///   dypho_run_dataset --dataset DIR_OR_BAG --out DIR [--camera NAME_OR_YAML] [--config YAML]
///                     [--mask flow|gt|none] [--max-frames N] [--no-eval] [--no-map] [--quiet]
///                     [--realtime [--realtime-speed S] [--realtime-queue N] | --late-mask-poses]
///                     [--resume DIR [--localization-only]]
///   dypho_run_dataset --print-config
///
/// This command line is stable: scripts depend on it.

#include <signal.h>
#include <sys/stat.h>

#include <atomic>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "dypho/common/atomic_file.h"
#include "dypho/common/frame_allocator.h"
#include "dypho/tools/camera_config.h"
#include "dypho/tools/evaluation.h"
#include "dypho/tools/frame_source.h"
#include "dypho/tools/map_views.h"
#include "dypho/mapping/gaussian_map_io.h"
#include "dypho/common/trajectory_io.h"
#include "dypho/pipeline/realtime_runner.h"
#include "dypho/pipeline/session_store.h"
#include "dypho/pipeline/slam_pipeline.h"
#include "dypho/tools/trajectory_plot.h"
#include "output_files.h"
#include "realtime_report.h"
#include "run_dataset_args.h"
#include "timing_csv.h"

namespace {

using namespace dypho;

/// Set by SIGINT/SIGTERM: the frame loop stops and everything processed so far is written.
std::atomic<bool> g_stop{false};
void onStopSignal(int) { g_stop = true; }
using namespace dypho::tools;
using namespace dypho::pipeline;
using dypho::run_dataset::Args;
using dypho::run_dataset::makeDirs;
using dypho::run_dataset::MaskWriter;
using dypho::run_dataset::parseArgs;
using dypho::run_dataset::realtimeSummary;
using dypho::run_dataset::TimingRow;
using dypho::run_dataset::usage;
using dypho::run_dataset::writeRealtimeCsv;
using dypho::run_dataset::writeTiming;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// Every frame's outcome, gathered by either frame loop (deterministic or realtime).
struct RunTally {
  std::size_t num_frames = 0;  ///< frames asked for: the sequence, cut to --max-frames
  std::size_t processed = 0;   ///< frames read and handed to the pipeline
  std::size_t lost = 0;        ///< posed frames whose tracking state was not kOk
  std::size_t num_keyframes = 0;
  std::vector<TimingRow> rows;                ///< one per posed frame (timing.csv)
  std::vector<double> totals;                 ///< work per posed frame [ms], for the median
  std::vector<std::string> unreadable;        ///< frames skipped because their files could not be read
  std::vector<std::string> out_of_order;      ///< frames dropped for a repeated or late stamp (stamp_gate.h)
  std::optional<RealtimeResult> realtime;     ///< --realtime only
  std::map<std::size_t, cv::Mat> view_masks;  ///< the mask of every --eval-every'th frame, by index
  std::vector<double> keyframe_stamps_s;      ///< frames that became keyframes
  double first_stamp_s = -1.0;                ///< stamp of the first posed or lost frame [s]
  long first_ok_index = -1;                   ///< first frame tracked OK and anchored (--resume: relocalised)
  double first_ok_stamp_s = -1.0;             ///< its stamp [s]
};

/// What the outputs step hands to the summary and the evaluation.
struct RunOutputs {
  std::vector<StampedPose> final_trajectory;  ///< trajectory.txt
  std::vector<StampedPose> trajectory;        ///< trajectory_online.txt
  std::size_t num_final_keyframes = 0;
  mapping::KeyframeEvaluation map_eval;  ///< default (zeros) with --no-map
  std::optional<MapViewRun> views;       ///< the map at every --eval-every'th frame (map built)
  /// trajectory.txt as it was before the tracker's end of run (final global BA), for the gain
  std::vector<StampedPose> final_trajectory_before_end;
  tracking::RunEnd run_end;                  ///< the tracker's end of run (final global BA)
  std::size_t keyframes_adopted = 0;         ///< keyframe poses taken from the map (pose_refinement)
  std::optional<SessionSaveReport> session;  ///< OUT/session as written (a map was built)
  std::string session_note;                  ///< why no session was written, when none was
};

/// The pipeline options: config/*.yaml with --config on top, plus --mask and --no-map.
PipelineOptions loadRunOptions(const Args& args, const std::string& config_dir) {
  PipelineOptions options = loadPipelineOptions(config_dir, args.config);
  options.mask_source = parseMaskSource(args.mask);
  options.build_map = args.build_map;
  options.mask_poses_one_frame_late = args.late_mask_poses;
  if (args.localization_only) options.tracking.localization_only = true;
  return options;
}

/// Opens --dataset, checks it has what --mask needs and logs what was opened.
std::unique_ptr<FrameSource> openDataset(const Args& args, const PipelineOptions& options,
                                         const std::string& config_dir) {
  std::unique_ptr<FrameSource> source = openFrameSource(args.dataset, args.camera, config_dir);
  if (options.mask_source == MaskSource::kExternal && !source->hasMasks()) {
    throw std::runtime_error("--mask gt needs a mask/ folder in the dataset (written by dypho_synth)");
  }
  std::cerr << "dypho_run_dataset: " << source->description() << ", " << source->size() << " frames, camera "
            << source->cameraName() << " (rolling-shutter readout " << source->rollingShutterReadoutMs()
            << " ms in its file), mask " << args.mask << "\n";
  for (const std::string& w : source->warnings()) std::cerr << "warning: " << w << "\n";
  return source;
}

/// Ctrl-C / SIGTERM: stop after the current frame and write what was processed.
void installStopHandlers() {
  struct sigaction stop_action {};
  stop_action.sa_handler = onStopSignal;
  sigaction(SIGINT, &stop_action, nullptr);
  sigaction(SIGTERM, &stop_action, nullptr);
}

/// --realtime: switches `options` to the graph's live policy and logs each change.
void applyRealtimePolicy(const Args& args, PipelineOptions& options) {
  if (args.realtime) {
    for (const std::string& change : applyLivePolicy(options))
      std::cerr << "dypho_run_dataset: realtime: " << change << "\n";
  }
}

/// Counts a frame that got a pose and keeps its timing row; `total_ms` is its work [ms].
void tallyPosedFrame(RunTally& tally, std::size_t index, double stamp_s, double load_ms, const FrameReport& report,
                     double total_ms) {
  const auto& tr = report.tracking;
  if (tally.first_stamp_s < 0.0) tally.first_stamp_s = stamp_s;
  if (tr.state != tracking::TrackingState::kOk) ++tally.lost;
  // Anchored: a new segment started after a failed search of a resumed map is not "found".
  if (tr.state == tracking::TrackingState::kOk && tr.anchored && tally.first_ok_index < 0) {
    tally.first_ok_index = static_cast<long>(index);
    tally.first_ok_stamp_s = stamp_s;
  }
  if (tr.keyframe) {
    ++tally.num_keyframes;
    tally.keyframe_stamps_s.push_back(stamp_s);
  }
  tally.rows.push_back({index, stamp_s, load_ms, report, total_ms});
  tally.totals.push_back(total_ms);
}

/// --realtime: plays the frames at their stamps (RealtimeRunner), tallies them, writes realtime.csv.
void runRealtimeFrames(const Args& args, const FrameSource& source, SlamPipeline& pipeline, RunTally& tally) {
  const std::size_t n = tally.num_frames;
  std::cerr << "dypho_run_dataset: realtime: frames released at their stamps x" << args.realtime_options.speed
            << ", mask queue of " << args.realtime_options.queue_capacity_frames << " frames (oldest skipped), "
            << "mask and tracking on their own threads (the tracking nodelet's live code)"
            << ", live mapping\n";
  std::vector<double> load_ms(n, 0.0);  // written by the producer thread, read after run()
  const RealtimeFrameLoader load = [&](std::size_t i) {
    const auto t0 = std::chrono::steady_clock::now();
    SourceFrame sf = source.load(i);
    load_ms[i] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return RealtimeInput{std::move(sf.frame), std::move(sf.mask)};
  };
  tally.realtime = RealtimeRunner(pipeline, args.realtime_options).run(n, load, &g_stop);
  tally.unreadable = tally.realtime->unreadable;
  for (const RealtimeProcessedFrame& f : tally.realtime->processed) {
    ++tally.processed;
    if (f.report.dropped) {
      tally.out_of_order.push_back("frame " + std::to_string(f.index) + ": " + f.report.message);
      continue;
    }
    const auto& tr = f.report.tracking;
    // Work on this frame, not the waits between the stages: render + mask + tracking + mapping.
    const double work_ms = f.report.render_ms + f.report.mask_ms + tr.times.total + f.report.mapping_ms;
    tallyPosedFrame(tally, f.index, timestampToSeconds(tr.stamp_ns), load_ms[f.index], f.report, work_ms);
    if (!f.mask.empty()) tally.view_masks[f.index] = f.mask;
  }
  writeRealtimeCsv(args.out + "/realtime.csv", *tally.realtime, n);
}

/// Default mode: every frame in order, as fast as possible (repeatable); --save-masks via `mask_writer`.
void runDeterministicFrames(const Args& args, const FrameSource& source, SlamPipeline& pipeline,
                            MaskWriter& mask_writer, RunTally& tally) {
  const std::size_t n = tally.num_frames;
  for (std::size_t i = 0; i < n && !g_stop; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    SourceFrame sf;
    try {
      sf = source.load(i);
    } catch (const std::exception& e) {
      // One bad file must not cost the run: skip the frame, name it in the summary, go on.
      tally.unreadable.push_back("frame " + std::to_string(i) + ": " + e.what());
      std::cerr << "\nwarning: skipping " << tally.unreadable.back() << "\n";
      continue;
    }
    ++tally.processed;
    const double load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const auto t1 = std::chrono::steady_clock::now();
    MaskedFrame masked = pipeline.maskFrame(sf.frame, sf.mask);
    if (args.save_masks && !masked.report.dropped)
      mask_writer.write(sf.frame.stamp_ns, masked.mask, sf.frame.bgr.size());
    if (args.build_map && args.eval_every > 0 && i % static_cast<std::size_t>(args.eval_every) == 0)
      tally.view_masks[i] = masked.mask.clone();
    FrameReport report = pipeline.trackFrame(std::move(masked));
    const double total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
    if (report.dropped) {  // repeated or late stamp in the list: counted and named, no pose
      tally.out_of_order.push_back("frame " + std::to_string(i) + ": " + report.message);
      continue;
    }
    tallyPosedFrame(tally, i, timestampToSeconds(sf.frame.stamp_ns), load_ms, report, total_ms);
    if (!args.quiet && (i % 10 == 0 || i + 1 == n)) {
      std::cerr << "\r[" << std::setw(5) << i + 1 << "/" << n << "] " << std::fixed << std::setprecision(1)
                << median(tally.totals) << " ms/frame (median), " << tally.num_keyframes << " keyframes, " << tally.lost
                << " not tracked, state " << tracking::toString(report.tracking.state) << "      " << std::flush;
    }
  }
}

/// Runs the first `num_frames` frames in the mode --realtime picks and ends the progress line.
RunTally runFrames(const Args& args, const FrameSource& source, SlamPipeline& pipeline, MaskWriter& mask_writer,
                   std::size_t num_frames) {
  RunTally tally;
  tally.num_frames = num_frames;
  if (args.realtime)
    runRealtimeFrames(args, source, pipeline, tally);
  else
    runDeterministicFrames(args, source, pipeline, mask_writer, tally);
  if (!args.quiet) std::cerr << "\n";
  if (g_stop)
    std::cerr << "dypho_run_dataset: stopped by a signal after " << tally.processed
              << " frames; writing what was processed\n";
  return tally;
}

/// OUT/session: the whole session (session_store.h), after the tracker's end, the map's final
/// refinement and the poses it refined, so it holds the final state. A run that never got a
/// keyframe has none to write (the note says so).
void saveRunSession(const Args& args, SlamPipeline& pipeline, RunOutputs& outputs) {
  try {
    outputs.session = saveSession(pipeline, sessionFolderIn(args.out), args.dataset);
  } catch (const std::logic_error& e) {
    outputs.session_note = e.what();
  }
}

/// --resume: loads the session before the first frame, for the camera of the dataset's first
/// frame; throws naming the file when it is refused.
void resumeSession(const Args& args, const FrameSource& source, SlamPipeline& pipeline) {
  const std::string dir = resolveSessionDir(args.resume);
  const auto t0 = std::chrono::steady_clock::now();
  const SessionManifest m = loadSession(pipeline, dir, source.load(0).frame.camera);
  std::cerr << "dypho_run_dataset: resumed " << dir << " (" << m.num_keyframes << " keyframes, " << m.num_map_points
            << " map points, " << m.num_gaussians << " Gaussians; saved " << m.created_utc << " from " << m.source
            << ") in " << std::fixed << std::setprecision(2)
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()
            << " s; searching it by relocalisation"
            << (args.localization_only ? ", localisation only (the maps are not changed)" : "") << "\n";
}

/// Writes the trajectories, keyframes, timing.csv, the --save-masks list and (unless --no-map) the
/// refined map with its per-keyframe renders.
RunOutputs writeOutputs(const Args& args, SlamPipeline& pipeline, const RunTally& tally,
                        const MaskWriter& mask_writer) {
  RunOutputs outputs;
  // trajectory.txt: every frame re-expressed with the final pose of the keyframe it was tracked
  // against (after local BA and loop closure; what ORB-SLAM saves); trajectory_online.txt: the
  // poses as published at frame time; keyframes.txt. The final map gets the final refinement.
  // The tracker's end of run (final global BA) comes first: trajectory.txt follows it.
  outputs.final_trajectory_before_end = toStampedPoses(pipeline.tracking().finalTrajectory());
  outputs.run_end = pipeline.finishTracking();
  pipeline.tracking().saveTrajectories(args.out);
  outputs.final_trajectory = toStampedPoses(pipeline.tracking().finalTrajectory());
  outputs.trajectory = toStampedPoses(pipeline.tracking().onlineTrajectory());
  outputs.num_final_keyframes = pipeline.tracking().keyframePoses().size();
  writeTiming(args.out + "/timing.csv", tally.rows);
  mask_writer.finish();
  if (args.build_map) {
    if (!args.quiet) std::cerr << "refining the map over all keyframes and writing it (map.ply, map.pcd)...\n";
    pipeline.mapping().save(args.out);   // finish() (final refinement), map.ply, map.pcd, gaussian_centres.pcd
    makeDirs(args.out + "/map_render");  // side-by-side input | rendered (colour, depth) per keyframe
    outputs.map_eval = pipeline.mapping().gaussians().evaluateKeyframes(args.out + "/map_render");
    // pose_refinement: the map's refined keyframe poses become the tracker's; the trajectories
    // are saved again on them.
    outputs.keyframes_adopted = pipeline.adoptMapKeyframePoses();
    if (outputs.keyframes_adopted > 0) {
      pipeline.tracking().saveTrajectories(args.out);
      outputs.final_trajectory = toStampedPoses(pipeline.tracking().finalTrajectory());
    }
    saveRunSession(args, pipeline, outputs);
  }
  return outputs;
}

/// --eval-every: the saved map.ply rendered at the final pose of every Nth frame and scored on its
/// static pixels; writes view_evaluation.txt. Frames whose mask was not kept are not scored.
MapViewRun scoreMapViews(const Args& args, const FrameSource& source, SlamPipeline& pipeline, const RunTally& tally,
                         const RunOutputs& outputs) {
  if (!args.quiet) std::cerr << "scoring the map at every " << args.eval_every << "th frame...\n";
  const mapping::GaussianMapperOptions& o = pipeline.mapping().gaussians().options();
  const mapping::GaussianMap map = mapping::loadGaussianPly(args.out + "/map.ply", o.sh_degree, o.max_gaussians);
  mapping::ViewEvaluationOptions view_options;
  view_options.every_nth_frame = args.eval_every;
  const ViewMaskLookup mask_of = [&](std::size_t index, Timestamp) {
    const auto it = tally.view_masks.find(index);
    return it == tally.view_masks.end() ? cv::Mat() : it->second;
  };
  MapViewRun views = evaluateMapViews(map, source, tally.num_frames, outputs.final_trajectory, tally.keyframe_stamps_s,
                                      mask_of, view_options, o.resolvedNumThreads());
  mapping::writeViewEvaluation(args.out + "/view_evaluation.txt", views.evaluation);
  return views;
}

/// The summary on stdout: frames, skips and drops, the realtime run, the mask prior, the time per
/// frame, the files written and the map.
void printRunSummary(const Args& args, SlamPipeline& pipeline, const RunTally& tally, const RunOutputs& outputs) {
  const mapping::MappingStageStats map_stats = pipeline.mapping().stats();
  const mask::MaskStageStats mask_stats = pipeline.mask().stats();
  std::cout << "frames:       " << tally.processed << " of " << tally.num_frames << " processed (" << tally.lost
            << " not tracked, " << tally.unreadable.size() << " unreadable and skipped, " << tally.out_of_order.size()
            << " dropped for a repeated or late stamp" << (g_stop ? ", stopped early by a signal" : "") << "), "
            << outputs.num_final_keyframes << " keyframes\n";
  for (const std::string& u : tally.unreadable) std::cout << "  skipped " << u << "\n";
  for (const std::string& u : tally.out_of_order) std::cout << "  dropped " << u << "\n";
  if (tally.realtime) std::cout << realtimeSummary(*tally.realtime, tally.num_frames, args.realtime_options) << "\n";
  std::cout << "mask prior:   " << mask_stats.frames_with_rendered_depth << " of " << mask_stats.frames
            << " frames with R_d (rendered depth), " << mask_stats.frames_with_ego_motion
            << " with the tracked ego-motion (" << mask_stats.frames_with_fresh_prior
            << " fresh: from the previous frame's pose, " << mask_stats.frames_with_prior_one_behind
            << " from the one before; " << mask_stats.pose_waits_timed_out << " waits for it timed out)\n";
  if (mask_stats.network_runs > 0) {
    std::cout << "network:      " << mask_stats.network_runs << " runs, " << mask_stats.network_results_late
              << " results too old on arrival (not used), " << mask_stats.frames_with_network_mask
              << " frames judged with a network mask\n";
  }
  std::cout << "time:         " << std::fixed << std::setprecision(1) << median(tally.totals)
            << (tally.realtime ? " ms/frame median of the processed frames' work (render + mask + tracking + mapping; "
                                 "waits between the stages not counted)\n"
                               : " ms/frame median (mask + tracking + mapping)\n")
            << "global BA:    at end " << tracking::describe(outputs.run_end.global_ba) << "; after loops "
            << tracking::describeAfterLoop(pipeline.tracking().odometry().globalBaStats()) << "\n";
  const tracking::FrameRefinementResult& refined = outputs.run_end.frame_refinement;
  if (pipeline.tracking().odometry().options().final_frame_refinement) {
    std::cout << "refined:      " << refined.frames_refined << " frames against the final map, " << refined.frames_kept
              << " kept as tracked (" << refined.frames_out_of_time << " for lack of time; " << refined.ms
              << " ms; tracking.final_frame_refinement)\n";
  }
  if (!args.resume.empty()) {
    std::cout << "resumed:      " << args.resume;
    if (tally.first_ok_index >= 0)
      std::cout << ", relocalised at frame " << tally.first_ok_index << ", " << std::setprecision(2)
                << tally.first_ok_stamp_s - tally.first_stamp_s << " s after the first frame\n";
    else
      std::cout << ", never relocalised (no frame tracked)\n";
  }
  if (outputs.session) {
    const SessionSaveReport& s = *outputs.session;
    std::cout << "session:      " << s.dir << " (" << s.manifest.num_keyframes << " keyframes, "
              << s.manifest.num_map_points << " map points, " << s.manifest.num_gaussians << " Gaussians; "
              << std::setprecision(1) << static_cast<double>(s.bytes) / 1e6 << " MB saved in " << std::setprecision(2)
              << s.seconds << " s)\n";
  } else if (args.build_map) {
    std::cout << "session:      not saved (" << outputs.session_note << ")\n";
  }
  if (outputs.keyframes_adopted > 0)
    std::cout << "pose refine:  " << outputs.keyframes_adopted
              << " keyframe poses refined with the map, trajectory.txt follows them\n";
  std::cout << "trajectory:   " << args.out << "/trajectory.txt\n"
            << "keyframes:    " << args.out << "/keyframes.txt\n"
            << "timing:       " << args.out << "/timing.csv\n";
  if (!args.build_map) {
    std::cout << "map:          not built (--no-map)\n";
  } else {
    const mapping::KeyframeEvaluation& map_eval = outputs.map_eval;
    std::cout << "map:          " << args.out << "/map.pcd (" << pipeline.mapping().numCloudPoints()
              << " points before voxel filter)\n"
              << "gaussians:    " << args.out << "/map.ply (" << map_stats.gaussians.num_gaussians << " Gaussians, "
              << map_stats.gaussians.iterations << " iterations, " << map_stats.gaussians.corrected_keyframes
              << " keyframe re-anchorings; " << map_stats.gaussians.num_keyframes << " of "
              << map_stats.keyframes_received << " keyframes in the map, " << map_stats.gaussians.merged_jobs
              << " jobs merged)\n"
              << "device:       " << pipeline.mapping().gaussians().deviceMessage() << "\n"
              << "map PSNR:     " << std::setprecision(2) << map_eval.psnr_db << " dB on static keyframe pixels ("
              << map_eval.num_keyframes << " keyframes, training resolution), depth L1 " << map_eval.depth_l1_m * 100.0
              << " cm\n";
    if (outputs.views) {
      std::cout << outputs.views->evaluation.report() << "              " << outputs.views->notes() << "; " << args.out
                << "/view_evaluation.txt\n";
    }
  }
}

/// "x cm, y deg (n pairs)" of the 1 s RPE; RPE needs pose pairs 1 s apart and a short (or
/// interrupted) run may have none: then "n/a (why)".
std::string rpeLine(const std::vector<StampedPose>& final_trajectory, const std::vector<StampedPose>& gt) {
  try {
    const RpeResult rpe = computeRpe(final_trajectory, gt, 1.0);
    std::ostringstream r;
    r << std::fixed << std::setprecision(2) << rpe.trans_rmse_m * 100 << " cm, " << rpe.rot_rmse_deg << " deg ("
      << rpe.num_pairs << " pairs)";
    return r.str();
  } catch (const std::exception& e) {
    return std::string("n/a (") + e.what() + ")";
  }
}

/// With ground truth (and without --no-eval): ATE and RPE of the final trajectory, ATE of the online
/// one; writes evaluation.txt and trajectory.png and prints the numbers.
void evaluateRun(const Args& args, const FrameSource& source, const RunTally& tally, const RunOutputs& outputs) {
  if (!args.eval || source.groundtruth().empty()) return;
  std::vector<StampedPose> gt = source.groundtruth();
  std::string gt_note = "raw ground truth";
  if (source.cameraName() == "bonn") {
    gt = applyBonnCorrection(gt);
    gt_note = "Bonn marker-to-camera correction applied";
  }
  const AteResult ate = computeAte(outputs.final_trajectory, gt);
  const std::string rpe_line = rpeLine(outputs.final_trajectory, gt);
  const AteResult ate_online = computeAte(outputs.trajectory, gt);
  std::ostringstream ev;
  ev << std::fixed << std::setprecision(2) << "ATE RMSE:     " << ate.rmse_m * 100 << " cm (mean " << ate.mean_m * 100
     << ", median " << ate.median_m * 100 << ", max " << ate.max_m * 100 << ", " << ate.num_pairs << " poses; "
     << gt_note << ")\n"
     << "RPE (1 s):    " << rpe_line << "\n"
     << "ATE online:   " << ate_online.rmse_m * 100
     << " cm (trajectory_online.txt, poses as published at frame time)\n";
  if (outputs.run_end.global_ba.ran) {
    ev << "ATE pre-GBA:  " << computeAte(outputs.final_trajectory_before_end, gt).rmse_m * 100
       << " cm (trajectory.txt before the final global BA)\n";
  }
  if (tally.realtime) {
    // Realtime: the ATE covers the frames that got a pose; how many did belongs beside it.
    const std::size_t n = tally.num_frames;
    ev << "posed:        " << tally.realtime->framesPosed() << " of " << n << " frames (fraction "
       << std::setprecision(3)
       << static_cast<double>(tally.realtime->framesPosed()) / static_cast<double>(std::max<std::size_t>(n, 1)) << "; "
       << tally.realtime->framesDropped() << " dropped by --realtime have no pose)\n";
  }
  writeFileAtomically(args.out + "/evaluation.txt", [&](std::ostream& os) { os << ev.str(); });
  writeTrajectoryPlotPng(args.out + "/trajectory.png", ate, source.description());
  std::cout << ev.str() << "evaluation:   " << args.out << "/evaluation.txt, " << args.out << "/trajectory.png\n";
}

/// Parse options -> open the dataset -> build the pipeline -> run the frames -> write the outputs
/// -> evaluate. Returns the exit status.
int run(const Args& args) {
  const std::string config_dir = defaultConfigDir();
  PipelineOptions options = loadRunOptions(args, config_dir);
  if (args.print_config) {
    writePipelineOptionsYaml(std::cout, options);
    return 0;
  }

  const std::unique_ptr<FrameSource> source = openDataset(args, options, config_dir);
  if (options.tracking.rolling_shutter_readout_ms < 0.0) {  // -1: the camera's
    options.tracking.rolling_shutter_readout_ms = source->rollingShutterReadoutMs();
  }
  installStopHandlers();
  applyRealtimePolicy(args, options);
  // Default: deterministic, the same run gives the same bits. --realtime: the graph's live policy.
  SlamPipeline pipeline(options, args.realtime ? mapping::MappingMode::kLive : mapping::MappingMode::kDeterministic);
  if (args.build_map) std::cerr << "dypho_run_dataset: " << pipeline.mapping().gaussians().deviceMessage() << "\n";
  if (!args.resume.empty()) resumeSession(args, *source, pipeline);
  makeDirs(args.out);  // after the inputs and the session were accepted: a refused run leaves no folder
  std::size_t n = source->size();
  if (args.max_frames >= 0) n = std::min<std::size_t>(n, static_cast<std::size_t>(args.max_frames));
  MaskWriter mask_writer(args.out);
  const RunTally tally = runFrames(args, *source, pipeline, mask_writer, n);

  RunOutputs outputs = writeOutputs(args, pipeline, tally, mask_writer);
  if (args.build_map && args.eval_every > 0) outputs.views = scoreMapViews(args, *source, pipeline, tally, outputs);
  printRunSummary(args, pipeline, tally, outputs);
  evaluateRun(args, *source, tally, outputs);
  return g_stop ? 130 : 0;  // 130: stopped by SIGINT, outputs written
}

}  // namespace

int main(int argc, char** argv) {
  dypho::keepFrameBuffersInProcess();  // as the nodelets do; no effect on results
  try {
    return run(parseArgs(argc, argv));
  } catch (const std::exception& e) {
    std::cerr << "dypho_run_dataset: error: " << e.what() << "\n";
    usage(std::cerr);
    return 1;
  }
}
