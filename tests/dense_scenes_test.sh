#!/usr/bin/env bash
# Dense model accuracy on the other simulated targets (issue 4: "same figures reported for a box, a cylinder and a
# mesh object"): for each of drivers/robot_sim/scenes/{box,cylinder,mesh}.scene, robot_sim renders the same orbit as
# pipeline_accuracy_test.sh (200 frames, 360 deg, default 800 mm radius, camera aimed at the target's centre) into a
# log (ground truth written aside, never fed to the pipeline), objscan_replay runs tracker, pose solver and dense
# modeler over it, and objscan_evaluate scores trajectory and surface against the truth after Sim(3) alignment.
# Pose bounds are issue 3's targets (as in pipeline_accuracy_test.sh); dense bounds are regression bounds above the
# level measured today, and the issue's dense targets are printed with MET / NOT MET. The mesh p90 is dominated by
# a few error regions (creases, the crevice at the floor) and moved by up to 50 % with the tracker rewrite alone
# (box 8.47 -> 4.92 mm, blob 1.72 -> 2.48 mm), so its bounds keep ~1.5x margin.
# 200 frames, not fewer: with 120 frames completeness drops by 0.07-0.08 on every scene and the automatic region of
# interest cuts the cylinder's lowest 20 mm, so the figures would no longer describe the issue's orbit.
set -euo pipefail
BIN="$1"; SRC="$2"
WORK=$(mktemp -d); trap 'rm -rf "$WORK"' EXIT
FRAMES=200
FAILED=0
fail() { echo "FAIL: $*"; exit 1; }

source "$SRC/tests/accuracy_lib.sh"

# scene NAME MESH_P90 MESH_MAX VOXEL_P90 MESH_COMPLETENESS VOXEL_COMPLETENESS: runs one scene and checks it against
# these regression bounds (mm, mm, mm, fraction, fraction).
scene() {
  local name="$1" mesh_p90="$2" mesh_max="$3" voxel_p90="$4" mesh_c="$5" voxel_c="$6" d="$WORK/$1" m
  mkdir -p "$d"
  render_orbit "$name" "$d"
  local gt="$d/gt/poses_gt.txt"
  "$BIN/objscan_replay" --log "$d/sim.lcmlog" --out "$d/out" > "$d/replay.out" 2>&1 \
    || { tail -30 "$d/replay.out"; fail "replay ($name)"; }
  echo "$name: pose solver, 6-DOF:"
  trajectory_checks "$name" "$d/out" "$gt"
  echo "$name: dense model:"
  for m in mesh voxels; do
    "$BIN/objscan_evaluate" surface "$d/out/model_$m.ply" "$d/gt/target_surface.ply" \
      --truth-mesh "$d/gt/target_mesh.ply" --align "$d/out/trajectory.txt" "$gt" --visible-from "$gt" \
      > "$d/$m.txt" || fail "evaluate $name $m"
  done
  info "$name mesh accuracy to the truth samples p90 / max (mm)" \
    "$(value sample_accuracy_p90 "$d/mesh.txt") / $(value sample_accuracy_max "$d/mesh.txt")"
  check "$name mesh accuracy p90 (mm)" "$(value accuracy_p90 "$d/mesh.txt")" "<=" "$mesh_p90"
  check "$name mesh accuracy max (mm)" "$(value accuracy_max "$d/mesh.txt")" "<=" "$mesh_max"
  check "$name voxel centres accuracy p90 (mm)" "$(value accuracy_p90 "$d/voxels.txt")" "<=" "$voxel_p90"
  check "$name mesh completeness (visible surface, 2 mm)" "$(value completeness "$d/mesh.txt")" ">=" "$mesh_c"
  check "$name voxel completeness (visible surface, 2 mm)" "$(value completeness "$d/voxels.txt")" ">=" "$voxel_c"
  check "$name mesh accuracy p90 (mm)" "$(value accuracy_p90 "$d/mesh.txt")" "<=" 1.0 target
  check "$name mesh accuracy max (mm)" "$(value accuracy_max "$d/mesh.txt")" "<=" 3.0 target
  check "$name voxel centres accuracy p90 (mm)" "$(value accuracy_p90 "$d/voxels.txt")" "<=" 1.5 target
  check "$name mesh completeness" "$(value completeness "$d/mesh.txt")" ">=" 0.95 target
}

# Measured 3 Dec, afternoon, with the first-steps epipolar search (affine_dense.h refine_first_steps; mesh p50, p90,
# max, completeness; voxel centres p90): box 0.109, 0.376, 2.96, 0.959, 1.02; cylinder 0.085, 0.310, 2.52, 0.986,
# 1.04; mesh (blob) 0.100, 0.338, 1.73, 0.990, 1.09.
# Measured 3 Dec, afternoon, with the blob's generator fixed (make_blob_mesh.py: r no longer depends on phi at the
# poles; before, each pole was a pinwheel of five spikes and dips with 7.5 mm of relief 8-9 mm from it, the cap's "bumps"
# below, and the blob stood on the south pole's spikes, the floor contact below): mesh (blob) 0.100, 0.340, 1.74,
# 0.991, 1.09 (the worst vertices are on a flank 26 mm above the floor); its mesh max bound is the issue's 3 mm too.
# The figures below are of the old blob.
# Measured 3 Dec (weakly voted mesh vertices refitted to their strong neighbours' surface, flared weak rims removed,
# weak_surface_refit.h; mesh p50, p90, max, completeness; voxel centres p90): box 0.109, 0.377, 2.96, 0.959, 1.02;
# cylinder 0.085, 0.308, 2.52, 0.986, 1.04; mesh (blob) 0.108, 0.382, 3.85, 0.952, 1.11 (over 3 mm: ~30 vertices
# of its flat cap, which the views see at grazing angles only, 3.0-3.8 mm inside, and 6 at the floor contact). The
# mesh max bounds of the box and the cylinder are the issue's 3 mm since then (the replay is deterministic).
# Accuracy is the exact distance to the surface the simulator rendered (--truth-mesh) since 2 Dec, night; the figures
# before were distances to the nearest of 1 random truth sample per mm^2, which add the samples' spacing (p90 0.86 mm
# for a perfect model) and are still printed. Measured 2 Dec, night (mesh p50, p90, max; voxel centres p90): box
# 0.109, 0.377, 3.27 (13 vertices ~3 mm outside one wall 30 mm above the floor), 1.02; cylinder 0.085, 0.310, 3.61
# (6 vertices at the floor contact), 1.04; mesh (blob) 0.108, 0.384, 3.85 (9 vertices at the floor contact 3.1 mm
# outside, ~60 on the cap 3 mm inside), 1.11. Completeness unchanged (it never used the samples' distances). The
# earlier figures below are to the samples.
# Mesh max bounds tightened on 2 Dec, night (5.5 / 5.5 / 6.0 -> 4.5 / 4.5 / 5.0 mm, about 1 mm over the values below).
# Measured (seed 1, 200 frames) since 2 Dec, late (pairs wait for the region; surface facing down within 14 mm of the
# floor dropped as the crevice; a crease face's plane from its group's mean when its far side is stray): box mesh p90
# 0.898, max 3.33, voxels 1.22, completeness 0.959 / 0.928; cylinder 0.903, 3.62, 1.25, 0.986 / 0.956; mesh (blob)
# 0.933, 3.94, 1.30, 0.953 / 0.946. Over 3 mm: the box's 7 vertices 3.3 mm outside one wall, the cylinder's 2 at the
# floor, the blob's cap middle (3.8 mm inside, 26 vertices) and 6 vertices at its floor contact. 2 Dec, afternoon (creases sharpened, SharpenCreases; triangles longer
# than 50 px need textured windows): box mesh p90 0.899, max 4.13, voxels 1.22, completeness 0.959 / 0.929; cylinder
# 0.904, 4.47, 1.25, 0.989 / 0.959; mesh (blob) 0.943, 4.51, 1.31, 0.958 / 0.951. Since 2 Dec (the pair's own LK matches where the tracker left
# the object bare, pair_matches.h): box mesh p90 0.936, max 4.08, voxels 1.22, completeness 0.962 / 0.933; cylinder 0.927, 4.43, 1.25,
# 0.982 / 0.959; mesh (blob) 0.945, 4.52, 1.31, 0.960 / 0.953 (its flat cap, which the tracker loses, is now modelled;
# the blob's max is the floor contact, 4-6 mm outside). Before, since 1 Dec, evening (curled hole rims peeled,
# marching_cubes.h; votes recomputed with the final poses): box mesh p90 0.962, max 5.78, voxels 1.26, completeness
# 0.952 / 0.923; cylinder 0.959, 6.72, 1.27, 0.970 / 0.944; mesh (blob) 0.904, 5.23, 1.28, 0.914 / 0.900. Without the
# re-vote: box 0.966, 4.14 (the re-vote lets a 19-vertex piece 5.8 mm inside one wall through), 1.26, 0.953 / 0.924;
# cylinder 0.965, 6.69, 1.29, 0.970 / 0.943; blob 0.905, 5.32, 1.29, 0.911 / 0.898. Before (hidden mesh parts removed,
# floor clearance 4 mm with the floor band, floor hypothesis in junction triangles, voxels follow the mesh,
# crease-preserving surface fit, one border ring peeled): box mesh p90 0.971, max 4.13, voxels 1.26, completeness 0.956
# / 0.925; cylinder 0.972, 6.68, 1.29, 0.972 / 0.943; mesh (blob) 0.907, 9.88, 1.29, 0.911 / 0.897. Before the surface
# fit and border peeling: box 1.035, 5.39, 1.26, 0.944 / 0.925; cylinder 0.994, 8.06, 1.29, 0.968 / 0.943; mesh (blob)
# 0.927, 11.5, 1.30, 0.921 / 0.900. Before (since 29 Nov accuracy is against the whole true surface, see
# objscan_evaluate): box mesh p90 1.04, voxels 1.27, completeness 0.910 / 0.889; cylinder 1.06, 1.37, 0.949 / 0.924;
# mesh (blob) 0.96, 1.32, 0.923 / 0.901. With the epipolar refinement searching +-1.5 px (step 0.25) instead of +-3 px
# (step 0.5): box 1.26, 1.38, 0.871 / 0.853; cylinder 1.10, 1.40, 0.929 / 0.904; blob 0.97, 1.32, 0.905 / 0.880 (mesh
# max 18 / 12 / 20 mm). Before small mesh pieces were dropped (< 1 % of the largest, after carving): box 1.52, cylinder
# 1.16, blob 0.99 (max 20 / 12 / 25). With the plane-only smoothing (radius 4): box 1.91, cylinder 1.30, blob 1.05.
# Before the surface-point smoothing and the relative fragment filter: box mesh p90 3.22, voxels 1.43, completeness
# 0.900 / 0.857; cylinder 1.94, 1.40, 0.937 / 0.903; blob 1.10, 1.33, 0.904 / 0.881. (Before the refinement-border
# check: box 4.92, 1.68; cylinder 2.21, 1.52; blob 2.48, 1.44.)
scene box 0.5 3.0 1.3 0.945 0.91
scene cylinder 0.5 3.0 1.3 0.97 0.94
scene mesh 0.5 3.0 1.3 0.97 0.96

[ "$FAILED" = 0 ] || fail "accuracy below the bounds above"
echo "PASS: dense model accuracy on the box, cylinder and mesh scenes"
