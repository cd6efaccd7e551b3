#!/usr/bin/env bash
# End-to-end accuracy on the simulated orbit (issues 3 and 4): robot_sim renders the 200-frame, 800 mm orbit around
# the sphere into a log (ground truth written aside, never fed to the pipeline), objscan_replay runs tracker, pose
# solver and dense modeler over it, and objscan_evaluate scores the results against the truth after Sim(3)
# alignment. Pose bounds are the issue's targets; dense bounds are regression bounds at the level measured today,
# and the issue's dense targets are printed with MET / NOT MET (see docs/benchmarks.md).
set -euo pipefail
BIN="$1"; SRC="$2"
WORK=$(mktemp -d); trap 'rm -rf "$WORK"' EXIT
FAILED=0
fail() { echo "FAIL: $*"; exit 1; }

source "$SRC/tests/accuracy_lib.sh"
render_orbit sphere "$WORK"
GT="$WORK/gt/poses_gt.txt"
# 6-DOF, full pipeline.
"$BIN/objscan_replay" --log "$WORK/sim.lcmlog" --out "$WORK/out6" > "$WORK/replay6.out" 2>&1 \
  || { tail -30 "$WORK/replay6.out"; fail "replay (6-DOF)"; }
echo "pose solver, 6-DOF:"
trajectory_checks 6dof "$WORK/out6" "$GT"

# 4-DOF (the robot's floor model), poses only.
"$BIN/objscan_replay" --log "$WORK/sim.lcmlog" --out "$WORK/out4" --no-dense --pose-model 4dof \
  > "$WORK/replay4.out" 2>&1 || { tail -30 "$WORK/replay4.out"; fail "replay (4-DOF)"; }
echo "pose solver, 4-DOF:"
trajectory_checks 4dof "$WORK/out4" "$GT"

echo "dense model (6-DOF poses):"
for m in mesh voxels; do
  "$BIN/objscan_evaluate" surface "$WORK/out6/model_$m.ply" "$WORK/gt/target_surface.ply" \
    --truth-mesh "$WORK/gt/target_mesh.ply" --align "$WORK/out6/trajectory.txt" "$GT" --visible-from "$GT" \
    > "$WORK/$m.txt" || fail "evaluate $m"
done
# Accuracy is the exact distance of the model to the surface the simulator rendered (--truth-mesh) since 2 Dec,
# night; before, it was the distance to the nearest of 1 random truth sample per mm^2, which adds the samples'
# spacing (a perfect model scores p90 0.86 mm that way); those figures are still printed (sample_accuracy_*).
# Measured 3 Dec, afternoon (the epipolar search scores the steps near the prediction first, affine_dense.h
# refine_first_steps): mesh p50 0.085, p90 0.348, max 2.80, completeness 0.970; voxel centres p90 1.11.
# Measured 3 Dec (weakly voted mesh vertices refitted to their strong neighbours' surface, flared weak rims removed,
# weak_surface_refit.h): mesh p50 0.085, p90 0.345, max 2.80, completeness 0.969; voxel centres p90 1.11,
# completeness 0.943. The mesh max bound is the issue's 3 mm since then.
# Measured 2 Dec, night: mesh p50 0.085, p90 0.349, max 3.49 (one vertex at the bottom of a 3.5 mm dent; to the
# samples: p90 0.940, max 3.56), completeness 0.968; voxel centres p90 1.11 (to the samples 1.32), completeness 0.943.
# Earlier figures below are to the samples.
# Regression bounds (the mesh max's tightened from 5.5 to 4.5 mm on 2 Dec, night: about 1 mm over today's value; the
# replay is deterministic, so only a change of the code or the scene moves it); measured 2 Dec, late (surface facing down within 14 mm of the floor dropped as the crevice,
# crevice_band_mm): mesh p90 0.941, max 3.56 (two single vertices 3.3-3.6 mm inside), completeness 0.969; voxels p90
# 1.32, completeness 0.943. 2 Dec, afternoon (creases sharpened; triangles longer than 50 px need textured windows,
# which removed the 3.5-4.6 mm dents that the affine map's chords left at z 60-80): mesh p90 0.950, max 5.42 (the
# floor contact, 4-5 mm outside in the shadowed crevice), completeness 0.968; voxels p90 1.34, completeness 0.942.
# Before, 2 Dec (the pair's own LK matches where the tracker left gaps, pair_matches.h): mesh p90
# 0.953, max 5.42, completeness 0.970; voxels p90 1.34, completeness 0.945. 1 Dec (curled hole rims peeled, votes
# recomputed with the final poses): mesh p90 0.935, max 6.34, completeness 0.965; voxels p90 1.33, completeness 0.938
# (before the curled rims: max 10.3).
info "mesh accuracy to the truth samples p90 / max (mm)" "$(value sample_accuracy_p90 "$WORK/mesh.txt") / $(value sample_accuracy_max "$WORK/mesh.txt")"
check "mesh accuracy p90 (mm)" "$(value accuracy_p90 "$WORK/mesh.txt")" "<=" 0.5
check "mesh accuracy max (mm)" "$(value accuracy_max "$WORK/mesh.txt")" "<=" 3.0
check "voxel centres accuracy p90 (mm)" "$(value accuracy_p90 "$WORK/voxels.txt")" "<=" 1.3
check "mesh completeness (visible surface, 2 mm)" "$(value completeness "$WORK/mesh.txt")" ">=" 0.95
check "voxel completeness (visible surface, 2 mm)" "$(value completeness "$WORK/voxels.txt")" ">=" 0.92
check "mesh accuracy p90 (mm)" "$(value accuracy_p90 "$WORK/mesh.txt")" "<=" 1.0 target
check "mesh accuracy max (mm)" "$(value accuracy_max "$WORK/mesh.txt")" "<=" 3.0 target
check "voxel centres accuracy p90 (mm)" "$(value accuracy_p90 "$WORK/voxels.txt")" "<=" 1.5 target
check "mesh completeness" "$(value completeness "$WORK/mesh.txt")" ">=" 0.95 target

[ "$FAILED" = 0 ] || fail "accuracy below the bounds above"
echo "PASS: pipeline accuracy on the simulated orbit"
