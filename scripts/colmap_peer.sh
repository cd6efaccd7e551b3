#!/usr/bin/env bash
# colmap_peer.sh — runs COLMAP's CPU sparse pipeline on an objscan dataset folder as a peer baseline and scores its
# camera trajectory against the dataset's ground truth, next to an objscan trajectory if one is given.
#
# Usage:
#   scripts/colmap_peer.sh DATASET_DIR OUT_DIR [options]
# Options:
#   --frames N                 use only the first N images (sorted by name; default all)
#   --rate HZ                  frame rate for timestamps: image NNNNNN.png -> t = NNNNNN / HZ s (default 30, the
#                              objscan convention, so the times match poses_gt.txt written by objscan_export)
#   --matcher M                auto (default: exhaustive up to 60 images, else sequential), exhaustive, sequential
#   --overlap N                sequential matcher: neighbours matched per image (default 10)
#   --vocab-tree FILE          sequential matcher: enable loop detection with this vocabulary tree (default off)
#   --threads N                COLMAP threads for extraction, matching and mapping (default 2)
#   --max-features N           SIFT features per image (default 8192, COLMAP's default)
#   --reuse-features           keep OUT_DIR/database.db from an earlier run on the same images and skip the feature
#                              extraction (its recorded time, OUT_DIR/logs/feature_extractor.time, still counts)
#   --objscan-trajectory FILE  also score this objscan TUM trajectory (mm) in the same table ...
#   --objscan-time S           ... with this wall time in s (measured by the caller)
#   --build DIR                objscan build folder holding bin/objscan_export and bin/objscan_evaluate
#                              (default: $OBJSCAN_BUILD, else the first of build, build-* under the repository)
#
# DATASET_DIR is an objscan dataset folder (what objscan_export writes, what the camera driver reads):
#   images/ (or the images directly), calib.yaml (OpenCV FileStorage: camera_matrix, distortion_coefficients,
#   image_width, image_height) and optionally poses_gt.txt (TUM camera-to-world, "# units: mm").
#
# Steps (all CPU, logs in OUT_DIR/logs/):
#   1. installs the Debian package colmap (3.8) with apt-get when the colmap command is missing (needs root; large);
#   2. OUT_DIR/images: links to the images used;
#   3. colmap feature_extractor: SiftExtraction.use_gpu 0, ImageReader.single_camera 1 with the known intrinsics
#      from calib.yaml (PINHOLE fx,fy,cx,cy, or OPENCV with distortion; principal point shifted by +0.5 px to
#      COLMAP's pixel convention) — see `objscan_export colmap-camera`;
#   4. colmap exhaustive_matcher or sequential_matcher (SiftMatching.use_gpu 0, overlap 10, loop detection only
#      with --vocab-tree);
#   5. colmap mapper with fixed intrinsics (Mapper.ba_refine_focal_length 0, ba_refine_principal_point 0,
#      ba_refine_extra_params 0); when it makes several models, the one with most registered images is used;
#   6. colmap model_converter to TXT (OUT_DIR/model_txt), then `objscan_export colmap-to-tum` turns images.txt
#      (cam_from_world) into OUT_DIR/colmap_tum.txt (camera-to-world, t from the image names);
#   7. `objscan_evaluate trajectory` against poses_gt.txt (Sim(3) alignment: COLMAP's scale is arbitrary).
# Output: a table (also in OUT_DIR/results.txt):
#   method  registered  ATE RMSE mm  rotation error deg (mean)  scale  wall time s
# registered = poses matched to a true pose (|dt| <= 5 ms) / frames used (COLMAP) or / images in the dataset (objscan).
# "wall time" for COLMAP is extraction + matching + mapping (not the install, conversion or scoring).
# Exit status: 0 when the table was printed, 1 on a failure (message on stderr), 2 on a bad command line.
set -euo pipefail

usage() { sed -n '2,40p' "$0" | sed 's/^# \{0,1\}//'; }
die() { echo "colmap_peer: error: $*" >&2; exit 1; }

[[ $# -ge 2 ]] || { usage >&2; exit 2; }
DATASET=$1
OUT=$2
shift 2
FRAMES=0
RATE=30
MATCHER=auto
OVERLAP=10
VOCAB_TREE=""
THREADS=2
MAX_FEATURES=8192
OBJSCAN_TRAJ=""
OBJSCAN_TIME=""
BUILD=${OBJSCAN_BUILD:-}
REUSE=0
while [[ $# -gt 0 ]]; do
  case $1 in
    --frames) FRAMES=$2; shift 2 ;;
    --rate) RATE=$2; shift 2 ;;
    --matcher) MATCHER=$2; shift 2 ;;
    --overlap) OVERLAP=$2; shift 2 ;;
    --vocab-tree) VOCAB_TREE=$2; shift 2 ;;
    --threads) THREADS=$2; shift 2 ;;
    --max-features) MAX_FEATURES=$2; shift 2 ;;
    --objscan-trajectory) OBJSCAN_TRAJ=$2; shift 2 ;;
    --objscan-time) OBJSCAN_TIME=$2; shift 2 ;;
    --build) BUILD=$2; shift 2 ;;
    --reuse-features) REUSE=1; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "colmap_peer: unknown option $1" >&2; usage >&2; exit 2 ;;
  esac
done
[[ $FRAMES =~ ^[0-9]+$ ]] || { echo "colmap_peer: --frames needs a number >= 0" >&2; exit 2; }
[[ $THREADS =~ ^[1-9][0-9]*$ ]] || { echo "colmap_peer: --threads needs a number >= 1" >&2; exit 2; }
[[ $OVERLAP =~ ^[1-9][0-9]*$ ]] || { echo "colmap_peer: --overlap needs a number >= 1" >&2; exit 2; }
[[ $MATCHER =~ ^(auto|exhaustive|sequential)$ ]] || { echo "colmap_peer: --matcher auto|exhaustive|sequential" >&2; exit 2; }
awk -v r="$RATE" 'BEGIN { exit !(r + 0 > 0) }' || { echo "colmap_peer: --rate must be > 0" >&2; exit 2; }
if [[ -n $OBJSCAN_TRAJ && -z $OBJSCAN_TIME ]]; then echo "colmap_peer: --objscan-trajectory needs --objscan-time" >&2; exit 2; fi
[[ -d $DATASET ]] || die "dataset folder $DATASET not found"
[[ -z $VOCAB_TREE || -f $VOCAB_TREE ]] || die "vocabulary tree $VOCAB_TREE not found"
[[ -z $OBJSCAN_TRAJ || -f $OBJSCAN_TRAJ ]] || die "objscan trajectory $OBJSCAN_TRAJ not found"

# --- objscan tools ---
REPO=$(cd "$(dirname "$0")/.." && pwd)
if [[ -z $BUILD ]]; then
  for candidate in "$REPO/build" "$REPO"/build-*; do
    if [[ -x $candidate/bin/objscan_export && -x $candidate/bin/objscan_evaluate ]]; then BUILD=$candidate; break; fi
  done
fi
EXPORT=$BUILD/bin/objscan_export
EVALUATE=$BUILD/bin/objscan_evaluate
[[ -x $EXPORT && -x $EVALUATE ]] ||
  die "objscan_export / objscan_evaluate not found (build tools/export and tools/evaluate; pass --build DIR)"

# --- COLMAP (installed only when this script runs and it is missing) ---
if ! command -v colmap > /dev/null; then
  [[ $(id -u) -eq 0 ]] || die "colmap is not installed; run: sudo apt-get install colmap"
  echo "colmap_peer: installing the Debian package colmap (large download)..." >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends colmap >&2 ||
    die "apt-get install colmap failed"
fi
export QT_QPA_PLATFORM=offscreen  # no display needed for the CPU commands

# --- inputs ---
IMAGE_DIR=$DATASET/images
[[ -d $IMAGE_DIR ]] || IMAGE_DIR=$DATASET
CALIB=""
for name in calib.yaml calib.yml calib.xml calib.json; do
  if [[ -f $DATASET/$name ]]; then CALIB=$DATASET/$name; break; fi
done
[[ -n $CALIB ]] || die "no calib.yaml in $DATASET"
read -r CAMERA_MODEL CAMERA_PARAMS < <("$EXPORT" colmap-camera "$CALIB") || die "cannot read $CALIB"
[[ -n ${CAMERA_PARAMS:-} ]] || die "cannot read $CALIB"
GT=$DATASET/poses_gt.txt

mkdir -p "$OUT/logs"
OUT=$(cd "$OUT" && pwd)
if [[ $REUSE -eq 1 && ! ( -f $OUT/database.db && -f $OUT/logs/feature_extractor.time ) ]]; then
  die "--reuse-features: no database.db with a recorded extraction time in $OUT"
fi
rm -rf "$OUT/images" "$OUT/sparse" "$OUT/model_txt" "$OUT/colmap_tum.txt"
[[ $REUSE -eq 1 ]] || rm -f "$OUT/database.db" "$OUT/logs/feature_extractor.time"
mkdir -p "$OUT/images" "$OUT/sparse"
ALL_IMAGES=()
for path in "$IMAGE_DIR"/*; do
  name=$(basename "$path")
  [[ -f $path && ${name,,} =~ \.(png|jpe?g|bmp|ppm|pgm|tiff?)$ ]] && ALL_IMAGES+=("$name")
done
[[ ${#ALL_IMAGES[@]} -gt 0 ]] || die "no images in $IMAGE_DIR"
mapfile -t ALL_IMAGES < <(printf '%s\n' "${ALL_IMAGES[@]}" | LC_ALL=C sort)
USED=${#ALL_IMAGES[@]}
if [[ $FRAMES -gt 0 && $FRAMES -lt $USED ]]; then USED=$FRAMES; fi
ABS_IMAGE_DIR=$(cd "$IMAGE_DIR" && pwd)
for ((i = 0; i < USED; ++i)); do ln -s "$ABS_IMAGE_DIR/${ALL_IMAGES[i]}" "$OUT/images/${ALL_IMAGES[i]}"; done
if [[ $MATCHER == auto ]]; then
  if [[ $USED -le 60 ]]; then MATCHER=exhaustive; else MATCHER=sequential; fi
fi
echo "colmap_peer: $USED images from $IMAGE_DIR, camera $CAMERA_MODEL $CAMERA_PARAMS, $MATCHER matcher," \
  "$THREADS threads" >&2

now() { date +%s.%N; }
run_step() {  # name, command...: runs a COLMAP step with its log in OUT/logs/name.log and prints its wall time
  local name=$1
  shift
  local start
  start=$(now)
  if ! "$@" > "$OUT/logs/$name.log" 2>&1; then
    tail -n 20 "$OUT/logs/$name.log" >&2
    die "colmap $name failed (log: $OUT/logs/$name.log)"
  fi
  awk -v a="$start" -v b="$(now)" 'BEGIN { printf "%.1f\n", b - a }' > "$OUT/logs/$name.time"
  echo "colmap_peer: $name $(cat "$OUT/logs/$name.time") s" >&2
}

if [[ $REUSE -eq 1 ]]; then
  echo "colmap_peer: reusing $OUT/database.db (extraction took $(cat "$OUT/logs/feature_extractor.time") s)" >&2
else
  run_step feature_extractor colmap feature_extractor \
    --database_path "$OUT/database.db" --image_path "$OUT/images" \
    --ImageReader.camera_model "$CAMERA_MODEL" --ImageReader.camera_params "$CAMERA_PARAMS" \
    --ImageReader.single_camera 1 \
    --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads "$THREADS" \
    --SiftExtraction.max_num_features "$MAX_FEATURES"
fi
if [[ $MATCHER == exhaustive ]]; then
  run_step matcher colmap exhaustive_matcher --database_path "$OUT/database.db" \
    --SiftMatching.use_gpu 0 --SiftMatching.num_threads "$THREADS"
else
  LOOP=(--SequentialMatching.loop_detection 0)
  [[ -n $VOCAB_TREE ]] && LOOP=(--SequentialMatching.loop_detection 1 --SequentialMatching.vocab_tree_path "$VOCAB_TREE")
  run_step matcher colmap sequential_matcher --database_path "$OUT/database.db" \
    --SiftMatching.use_gpu 0 --SiftMatching.num_threads "$THREADS" \
    --SequentialMatching.overlap "$OVERLAP" "${LOOP[@]}"
fi
run_step mapper colmap mapper --database_path "$OUT/database.db" --image_path "$OUT/images" \
  --output_path "$OUT/sparse" --Mapper.num_threads "$THREADS" \
  --Mapper.ba_refine_focal_length 0 --Mapper.ba_refine_principal_point 0 --Mapper.ba_refine_extra_params 0
COLMAP_TIME=$(cat "$OUT"/logs/{feature_extractor,matcher,mapper}.time | awk '{ s += $1 } END { printf "%.1f", s }')

# --- the largest model -> TXT -> TUM ---
BEST=""
BEST_COUNT=0
MODELS=0
for model in "$OUT"/sparse/*/; do
  [[ -f $model/images.bin ]] || continue
  MODELS=$((MODELS + 1))
  index=$(basename "$model")
  mkdir -p "$OUT/model_txt/$index"
  colmap model_converter --input_path "$model" --output_path "$OUT/model_txt/$index" --output_type TXT \
    > "$OUT/logs/model_converter_$index.log" 2>&1 || die "colmap model_converter failed on $model"
  count=$("$EXPORT" colmap-to-tum "$OUT/model_txt/$index/images.txt" "$OUT/model_txt/$index/tum.txt" --rate "$RATE" |
    awk '$1 == "images" { print $2 }')
  if [[ $count -gt $BEST_COUNT ]]; then BEST=$index; BEST_COUNT=$count; fi
done
[[ -n $BEST ]] || echo "colmap_peer: COLMAP reconstructed no model" >&2
if [[ -n $BEST ]]; then
  cp "$OUT/model_txt/$BEST/tum.txt" "$OUT/colmap_tum.txt"
  echo "colmap_peer: $MODELS model(s); using sparse/$BEST with $BEST_COUNT of $USED images" >&2
fi

# --- scoring ---
# score METHOD TRAJECTORY WALL_S FRAMES: prints one table row (registered = poses matched to the truth / FRAMES).
score() {
  local method=$1 traj=$2 wall=$3 frames=$4 matched="-" ate="-" rot="-" scale="-" out
  if [[ -n $traj && -f $GT ]]; then
    if out=$("$EVALUATE" trajectory "$traj" "$GT" 2> "$OUT/logs/evaluate_$method.log"); then
      matched=$(awk '$1 == "matched" { print $2 }' <<< "$out")
      ate=$(awk '$1 == "ate_rmse" { print $2 }' <<< "$out")
      rot=$(awk '$1 == "rotation_mean_deg" { print $2 }' <<< "$out")
      scale=$(awk '$1 == "scale" { print $2 }' <<< "$out")
    else
      echo "colmap_peer: scoring $method failed: $(cat "$OUT/logs/evaluate_$method.log")" >&2
      matched=$(grep -vc '^#' "$traj" || true)
    fi
  elif [[ -n $traj ]]; then
    matched=$(grep -vc '^#' "$traj" || true)
  else
    matched=0
  fi
  printf '%-10s %10s %12s %12s %14s %10s\n' "$method" "$matched/$frames" "$ate" "$rot" "$scale" "$wall"
}
[[ -f $GT ]] || echo "colmap_peer: no poses_gt.txt in $DATASET: registered frames only, no errors" >&2
{
  printf '%-10s %10s %12s %12s %14s %10s\n' method registered ate_rmse_mm rot_mean_deg scale wall_s
  score colmap "$([[ -n $BEST ]] && echo "$OUT/colmap_tum.txt")" "$COLMAP_TIME" "$USED"
  if [[ -n $OBJSCAN_TRAJ ]]; then score objscan "$OBJSCAN_TRAJ" "$OBJSCAN_TIME" "${#ALL_IMAGES[@]}"; fi
} | tee "$OUT/results.txt"
