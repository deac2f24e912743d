#!/usr/bin/env bash
# Regenerate the structure of the SUPER paper's Table 2 (TuSimple) and Table 4 (KITTI ego lane,
# BEV) plus the Fig. 9 ego/3-lane modes on the real frames of ../shared/data, with the shipped
# simulator-trained segmentation model (onnx:super_seg_v2: the default super_seg_v4 trained on 99 of
# these 129 TuSimple frames) and the SUPER lane fit. Writes reports/paper_tables/.
#
# Usage: pipelines/paper_tables_real.sh [DATA] [WORK] [OUT]
#   DATA defaults to $SLT_REALDATA or ../shared/data; WORK to a fresh temporary folder; OUT to
#   reports/paper_tables (relative to the repository, so records name repository paths).
set -euo pipefail
REPO="$(cd "$(dirname "$0")/.." && pwd)"
DATA="${1:-${SLT_REALDATA:-$REPO/../shared/data}}"
WORK="${2:-$(mktemp -d)}"
cd "$REPO"  # records and tables name their files relative to the repository
OUT="${3:-reports/paper_tables}"
REC="$OUT/records"; REC0="$OUT/records_no_time_gate"; PRED="$OUT/predictions"
rm -rf "$REC" "$REC0" "$PRED"
mkdir -p "$WORK/kitti_frames" "$REC" "$REC0" "$PRED"
LABELS="$DATA/tusimple/train_frames/labels.json"
N=$(grep -c raw_file "$LABELS")  # labelled frames
run() { echo "+ $*" >&2; "$@"; }

# TuSimple: 129 real frames (each the labelled 20th frame of a different 0313 clip)
run slt segment "$DATA/tusimple/train_frames" --out "$WORK/seg" --backend onnx --model super_seg_v2 --camera tusimple
for sc in sc "no sc"; do
  for sq in "no sq" sq; do
    tag="${sc// /}_${sq// /}"
    fit=(slt lanes fit "$WORK/seg" --camera tusimple --out "$WORK/lanes_$tag.parquet")
    [[ $sc == "no sc" ]] && fit+=(--no-slope)
    [[ $sq == sq ]] && fit+=(--sequential)
    run "${fit[@]}"
    run slt lanes export-tusimple "$WORK/lanes_$tag.parquet" --camera tusimple \
      --tasks "$LABELS" --out "$PRED/tusimple_$tag.json"
    run slt eval tusimple "$PRED/tusimple_$tag.json" "$LABELS" --row "$sq" --column "$sc" \
      --save "$REC/t2_$tag.json"
    run slt eval tusimple "$PRED/tusimple_$tag.json" "$LABELS" --row "$sq" --column "$sc" \
      --no-time-gate --save "$REC0/t2_$tag.json"
  done
done
for mode in ego 3lane; do
  run slt eval tusimple "$PRED/tusimple_sc_nosq.json" "$LABELS" --mode "$mode" --row "SUPER sc" \
    --column "TuSimple $N" --save "$REC/f9_$mode.json"
  run slt eval tusimple "$PRED/tusimple_sc_nosq.json" "$LABELS" --mode "$mode" --row "SUPER sc" \
    --column "TuSimple $N" --no-time-gate --save "$REC0/f9_$mode.json"
done

# KITTI um_000000: ego lane in the bird's-eye view
ln -sf "$DATA/kitti_road/image_um_000000.png" "$WORK/kitti_frames/um_000000.png"
run slt segment "$WORK/kitti_frames" --out "$WORK/kseg" --backend onnx --model super_seg_v2 --camera kitti
for sc in sc "no sc"; do
  tag="${sc// /}"
  fit=(slt lanes fit "$WORK/kseg" --camera kitti --out "$WORK/klanes_$tag.parquet")
  [[ $sc == "no sc" ]] && fit+=(--no-slope)
  run "${fit[@]}"
  run slt lanes export-kitti "$WORK/klanes_$tag.parquet" --camera kitti --out "$PRED/kitti_$tag"
  for rec in "$REC" "$REC0"; do
    run slt eval kitti "$PRED/kitti_$tag" "$DATA/kitti_road" --row "SUPER $sc" \
      --save "$rec/t4_$tag.json"
  done
done

for fmt in md tex parquet; do
  run slt tables paper "$REC"/*.json --out "$OUT/paper_tables.$fmt"
  run slt tables paper "$REC0"/*.json --out "$OUT/paper_tables_no_time_gate.$fmt"
done
echo "work folder: $WORK" >&2
