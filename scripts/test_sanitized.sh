#!/bin/bash
# Builds the ROS-free cores, tools and unit tests with plain CMake (no catkin, no ROS: the
# dependency check of the cores) under AddressSanitizer + UndefinedBehaviorSanitizer, and runs
# the unit tests; any sanitizer report fails the run. The whole-system dataset runs
# (test_datasets) are left to the optimised build in scripts/test.sh.
# Usage: test_sanitized.sh [BUILD_DIR]
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build-sanitized}"
JOBS="${DYPHO_JOBS:-$(nproc)}"
# -g1: line tables and function names, all a sanitizer report's stack needs; full -g (types,
# locals) made the compiles about 30 % slower and the objects 3.5 times larger.
FLAGS="-O1 -g1 -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
# The test executables' own files (the tests, not the code they test) are compiled with ASan
# only: UBSan made them 1.3-1.9 times slower to compile (gtest, Eigen and OpenCV templates) and
# they were 543 of the build's 968 compile-seconds. The cores and tools keep both sanitizers;
# header code that a test file instantiates may lose its UBSan checks where the linker keeps the
# test file's copy.
TEST_FLAGS="-fno-sanitize=undefined"
# The rasterizer's tile kernels and the synthetic generator's ray caster, where the tests spend
# most of their time, at -O2 (DYPHO_HOT_LOOP_COMPILE_OPTIONS): every check stays; one pipeline
# test took 127 s instead of 163 s.
HOT_FLAGS="-O2"
# The other modules' tests render their synthetic input frames with a second build of the
# generator at -O2 without the sanitizers (DYPHO_SYNTH_INPUT_COMPILE_OPTIONS, tools/synth.cmake):
# the renders were 27-80 % of the pipeline and tracking tests' samples under them. The generator's
# own tests (test_synthetic_*) use its sanitized build.
SYNTH_INPUT_FLAGS="-O2;-fno-sanitize=all"
mkdir -p "$BUILD"
# DYPHO_UNITY_LIBRARIES: the libraries compiled eight files at a time (573 -> 492 s for the unit
# tests' build on 2 cores); the code and the checks are the same.
cmake -S "$ROOT" -B "$BUILD" -DDYPHO_WITH_ROS=OFF -DDYPHO_WITH_CUDA=OFF -DCMAKE_BUILD_TYPE=None \
      -DDYPHO_UNITY_LIBRARIES=ON \
      -DDYPHO_TEST_TIMEOUT_SCALE=4 -DDYPHO_TEST_COMPILE_OPTIONS="$TEST_FLAGS" \
      -DDYPHO_HOT_LOOP_COMPILE_OPTIONS="$HOT_FLAGS" -DDYPHO_SYNTH_INPUT_COMPILE_OPTIONS="$SYNTH_INPUT_FLAGS" \
      -DCMAKE_CXX_FLAGS="$FLAGS" -DCMAKE_C_FLAGS="$FLAGS" \
      -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
      -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" > "$BUILD/configure.log" 2>&1 \
  || { cat "$BUILD/configure.log"; exit 1; }
# The cores must not include ROS headers (checked by building them without ROS) ...
if grep -rlE '#include <(ros|sensor_msgs|cv_bridge|tf2|nodelet)/' "$ROOT"/dypho_*/src/core "$ROOT"/dypho_*/include \
     "$ROOT"/dypho_pipeline/src 2>/dev/null; then
  echo "test_sanitized.sh: a core includes a ROS header (files above)" >&2
  exit 1
fi
cd "$BUILD"
# Only the unit tests and what they need (`unit_tests`; the tools, benchmarks and test_datasets
# are built, optimised, by scripts/build.sh).
cmake --build "$BUILD" -j "$JOBS" --target unit_tests
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Two (JOBS) at a time, the longest first (COST in the CMakeLists): the unit tests are mostly
# single-threaded, and under the sanitizers they took 15 of the suite's 50 minutes one at a time
# on 2 cores. The realtime runs of test_dypho_pipeline (they play frames at their stamps) run
# alone after the others; GTEST_FILTER names them, and no other test has tests of that name.
REALTIME='RealtimeRunner.*'
# Left out here, run only in the optimised build (scripts/test.sh): GaussianMapper's 100-frame
# ghost check took 158 of the mapper test's 182 s under ASan. What it runs does run here: training
# on keyframes with people masked in SlamPipeline.* (synthetic sequences with people, flow mask,
# mapping on), densify and prune in GaussianMapper.TrainingReducesTheLoss...
# Also left to the optimised build: three long repetitions of code that shorter tests run here
# (together about 10 of the sanitized phase's 27 minutes on 2 cores):
#  - SyntheticTracking.RedundantKeyframesAreRemovedOnRepeatedPasses: three passes over the room;
#    tracking, local BA and keyframe culling on each (the tracker's other synthetic tests);
#  - SlamPipeline.RepeatableToTheBitWithRenderedDepth: the pipeline run twice to compare bits;
#    SlamPipeline.LocalBaCorrectionsReachTheGaussianMap runs the pipeline here (without R_d: with
#    it, 172 s under ASan against 63 s), and DropsRepeatedAndLateFramesRestartsWhenTimeJumpsBack
#    runs it with R_d, across a restart;
#  - MissingFrames.DroppedFramesDoNotMoveTheTrajectory: 150 frames tracked three times.
# and the long runs on the shared real sequences, whose code shorter real-data tests run here
# (3-13 s each optimised, 4-20 times that under ASan):
#  - DynamicMaskRealData.TumRpyDeskEdgesStayBehindTheBackgroundOnFastTurns and
#    TumRpyStaticDeskNeedsNoFreshPose: the mask on fr1's 150 frames twice over
#    (TumRpyStaticDeskIsNotMaskedOnTheFirstFastTurns and TumRpyFirstFastTurnsWithPosesThreeFramesOld
#    run the same masker on 40 of them, with the true and with stale poses);
#  - RgbdOdometryRealData.BonnCrowdRough: the tracker on 200 Bonn frames (TumFr1RpyAccuracy runs
#    it on 150 fr1 frames);
#  - SessionStore.ResumedRunRelocalisesAndStaysInTheSameFrame: a run saved and resumed through
#    the pipeline (SessionStore.RoundTripThroughAFreshPipeline saves and loads one, and
#    TrackerSessionResume.FirstFrameAfterRestoreIsRelocalisedInTheLoadedMap relocalises in it).
# and the Gaussian map's longest training with keyframe pose refinement (an option, off by
# default; 500 iterations at full resolution; without it the mapper test took 189 s under ASan in
# a fresh clone on 2 cores, 226 s with it):
#  - PoseRefinement.AWrongKeyframePoseMovesTowardsTheMap (StepsBeyondTheBoundAreNotApplied trains
#    150 iterations with it here).
# and two more cases of code that runs here on other inputs (together about 75 s of the phase's
# 1350 test-seconds on 2 cores):
#  - the mask's regression on the half-sphere with seeds 3 and 5 (MaskRegression /1 and /2, 24 s
#    each): the same masker runs here on seed 1 (/0) and on the xyz path (/3);
#  - SyntheticTracking.DenseRefinementMakesEachFrameMorePrecise (25 s): the tracker twice over
#    60 frames, with and without the dense refinement (an option, off by default); the dense
#    aligner's own tests (DenseRgbdAligner.*) run here.
# and the generator's first image for 20 layouts (SynthPeople.EveryPersonIsInsideTheFirstImage,
# 45 s here, 7 s optimised): the same layouts and renders run here in the other SynthPeople tests.
# and two more of the same kind (together 88 of the phase's test-seconds on 2 cores, 7.5 s optimised):
#  - ExposureGauge.TheMapMovesIntoTheMeanExposureAndKeyframeRendersStay (55 s in the mapper's
#    test, which no other test of its kind may run beside): the map trained twice with the
#    exposure compensation, an option off by default, whose training runs here in
#    GaussianMapper.ExposureCompensationFollowsABrightnessChange;
#  - SyntheticScene.PeopleCoverAGoodPartOfTheImage (33 s): the generator's statistics over 100
#    renders; its renders run here in the other SyntheticScene tests.
# and the mask on the generator's fast turns without a prediction (13 s here, 2 s optimised): the
# flow's rigid fit from a still camera runs here in EgoMotion.RigidFitExplainsTheStaticScene...
# (from identity and from a stale pose), and the masker's fit-then-warp path with stale poses in
# DynamicMaskRealData.TumRpyFirstFastTurnsWithPosesThreeFramesOld:
#  - DynamicMasker.WithoutAPredictionTheBackgroundFollowsTheFlowsMotion.
# and the mask on the same turns three times over with fresh predictions that miss jerks (3 s
# optimised): the masker's flow-then-warp path with fresh poses runs here in
# DynamicMaskRealData.TumRpyStaticDeskIsNotMaskedOnTheFirstFastTurns (true poses, 40 frames):
#  - DynamicMasker.AFreshPredictionThatMissedAJerkDoesNotMaskTheStaticView.
# and the tracker twice over the same frames, with local BA on its own thread and without (33 s
# here): the threaded local BA runs here in SyntheticTracking.LocalBaOnItsOwnThreadIsApplied...
#  - SyntheticTracking.LocalBaOnItsOwnThreadGivesTheSameMap.
# and eight more repeats (about 290 of the phase's test-seconds on 2 cores, 38 s optimised):
#  - RealtimeRunner.DefaultDeterministicRunIsUnaffected (30 s here, and the realtime tests run
#    alone): the pipeline three times over the same frames to compare the poses bit for bit; the
#    realtime runner and both deterministic paths run here in the other RealtimeRunner and
#    SlamPipeline tests;
#  - DynamicMaskRealData.TumRpyPredictionTwoFramesOldKeptForTheFlow (59 s): the mask on fr1's 150
#    frames twice; the kept stale prediction's path runs here on 40 of them in
#    PredictionOlderThanKeptTakesTheFitForBoth (its bound of two frames);
#  - the mask's regression while catching up with seeds 3 and 5 (MaskRegression /1 and /2 of
#    MeetsTheIssueBoundsWhileCatchingUp, 11 s each): seed 1 and the xyz path run here;
#  - DynamicMasker.ABackgroundCarriedWithAWrongMotionLaterInTheTurnsIsRelearnt (18 s): the same
#    relearning as ABackgroundCarriedWithAWrongMotionIsRelearnt, six frames later;
#  - SlamPipeline.RefinedKeyframePosesGoBackToTracking (90 s beside the mapper's test): the map's
#    keyframe pose refinement (an option, off by default) in the whole pipeline; the refinement
#    runs here in PoseRefinement.StepsBeyondTheBoundAreNotApplied, the pipeline with the map in
#    SlamPipeline.LocalBaCorrectionsReachTheGaussianMap;
#  - PoseRefinement.ATrackingCorrectionKeepsTheRefinementsOffset (33 s): 300 iterations of the
#    same refinement with a tracking correction between them (re-anchoring runs here in
#    GaussianMapper.PoseCorrectionReanchorsTheKeyframesGaussians);
#  - SlamPipeline.MaskPosesOneFrameLateGiveEveryMaskAStalePrediction (34 s): the pipeline twice
#    over 30 frames to count the mask's predictions with the deterministic loop's stand-in for
#    live timing (an option for tests); the masker's stale predictions run here in
#    DynamicMaskRealData.PredictionOlderThanKeptTakesTheFitForBoth and
#    TumRpyFirstFastTurnsWithPosesThreeFramesOld.
OPTIMISED_ONLY='GaussianMapper.SyntheticSequenceHasNoGhosts:SyntheticTracking.RedundantKeyframesAreRemovedOnRepeatedPasses'
OPTIMISED_ONLY+=':SlamPipeline.RepeatableToTheBitWithRenderedDepth:MissingFrames.DroppedFramesDoNotMoveTheTrajectory'
OPTIMISED_ONLY+=':DynamicMaskRealData.TumRpyDeskEdgesStayBehindTheBackgroundOnFastTurns'
OPTIMISED_ONLY+=':DynamicMaskRealData.TumRpyStaticDeskNeedsNoFreshPose:RgbdOdometryRealData.BonnCrowdRough'
OPTIMISED_ONLY+=':SessionStore.ResumedRunRelocalisesAndStaysInTheSameFrame'
OPTIMISED_ONLY+=':PoseRefinement.AWrongKeyframePoseMovesTowardsTheMap'
OPTIMISED_ONLY+=':Sequences/MaskRegression.MeetsTheIssueBoundsWithGroundTruthPosePrior/1'
OPTIMISED_ONLY+=':Sequences/MaskRegression.MeetsTheIssueBoundsWithGroundTruthPosePrior/2'
OPTIMISED_ONLY+=':SyntheticTracking.DenseRefinementMakesEachFrameMorePrecise'
OPTIMISED_ONLY+=':SynthPeople.EveryPersonIsInsideTheFirstImage'
OPTIMISED_ONLY+=':ExposureGauge.TheMapMovesIntoTheMeanExposureAndKeyframeRendersStay'
OPTIMISED_ONLY+=':SyntheticScene.PeopleCoverAGoodPartOfTheImage'
OPTIMISED_ONLY+=':DynamicMasker.WithoutAPredictionTheBackgroundFollowsTheFlowsMotion'
OPTIMISED_ONLY+=':DynamicMasker.AFreshPredictionThatMissedAJerkDoesNotMaskTheStaticView'
OPTIMISED_ONLY+=':SyntheticTracking.LocalBaOnItsOwnThreadGivesTheSameMap'
OPTIMISED_ONLY+=':RealtimeRunner.DefaultDeterministicRunIsUnaffected'
OPTIMISED_ONLY+=':DynamicMaskRealData.TumRpyPredictionTwoFramesOldKeptForTheFlow'
OPTIMISED_ONLY+=':Sequences/MaskRegression.MeetsTheIssueBoundsWhileCatchingUp/1'
OPTIMISED_ONLY+=':Sequences/MaskRegression.MeetsTheIssueBoundsWhileCatchingUp/2'
OPTIMISED_ONLY+=':DynamicMasker.ABackgroundCarriedWithAWrongMotionLaterInTheTurnsIsRelearnt'
OPTIMISED_ONLY+=':SlamPipeline.RefinedKeyframePosesGoBackToTracking'
OPTIMISED_ONLY+=':PoseRefinement.ATrackingCorrectionKeepsTheRefinementsOffset'
OPTIMISED_ONLY+=':SlamPipeline.MaskPosesOneFrameLateGiveEveryMaskAStalePrediction'
echo "test_sanitized.sh: not run under the sanitizers (optimised build only): $OPTIMISED_ONLY"
status=0
GTEST_FILTER="-$REALTIME:$OPTIMISED_ONLY" ctest --output-on-failure -j "$JOBS" --timeout 4800 -E "^test_datasets$" || status=1
GTEST_FILTER="$REALTIME-$OPTIMISED_ONLY" ctest --output-on-failure -j 1 --timeout 4800 -R "^test_dypho_pipeline$" || status=1
exit "$status"
