#!/usr/bin/env bash
# Download public stereo datasets with ground truth from their official sites, for a USER to run by hand.
# Nothing in the build or the tests calls this script. Read each licence before you use the data.
#
#   data/fetch_datasets.sh                 list the sources, their licences and what gets fetched
#   data/fetch_datasets.sh DEST [SET...]   download into DEST; SET = kitti2012 kitti2015 middlebury2006
#                                          middlebury2014 middeval3 (default: all of them)
#
# The layout that scripts/eval.sh reads is ../shared/data (see its README.md). After a download, copy or link
# the files you need there (e.g. KITTI 2012 training/image_0, image_1, disp_noc, disp_occ), or point
# IELAS_DATA at a folder with that layout. Direct links were copied from the official pages; they were not
# reachable from the machine this was written on, so a link may have moved: the page URL is printed with it.
# Sets without a public direct link (New Tsukuba, FlyingThings3D, Middlebury 2001/2003/v2) are listed only.
set -euo pipefail

list_sources() {
  cat <<'EOF'
kitti2012      KITTI Stereo 2012 (Geiger, Lenz, Urtasun, CVPR 2012), ~2 GB
               page: https://www.cvlibs.net/datasets/kitti/eval_stereo_flow.php?benchmark=stereo
               file: https://s3.eu-central-1.amazonaws.com/avg-kitti/data_stereo_flow.zip
               licence: CC BY-NC-SA 3.0 (non-commercial); the site asks you to register first.
kitti2015      KITTI Stereo 2015 (Menze, Geiger, CVPR 2015), ~2 GB
               page: https://www.cvlibs.net/datasets/kitti/eval_scene_flow.php?benchmark=stereo
               file: https://s3.eu-central-1.amazonaws.com/avg-kitti/data_scene_flow.zip
               licence: CC BY-NC-SA 3.0 (non-commercial); the site asks you to register first.
middlebury2006 Middlebury 2006, half size, 2 views (Scharstein, Pal, CVPR 2007; Hirschmüller, Scharstein, CVPR 2007)
               page: https://vision.middlebury.edu/stereo/data/scenes2006/
               files: https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/<Scene>-2views.zip
                      for Cloth3, Reindeer, Wood2
               licence: permission to use and publish; cite the papers.
middlebury2014 Middlebury 2014 Motorcycle (Scharstein et al., GCPR 2014)
               page: https://vision.middlebury.edu/stereo/data/scenes2014/
               file: https://vision.middlebury.edu/stereo/data/scenes2014/zip/Motorcycle-perfect.zip
               licence: permission to use and publish; cite the paper.
middeval3      Middlebury Evaluation v3, quarter size, training images + GT (Scharstein et al., GCPR 2014)
               page: https://vision.middlebury.edu/stereo/submit3/
               files: https://vision.middlebury.edu/stereo/submit3/zip/MiddEval3-data-Q.zip
                      https://vision.middlebury.edu/stereo/submit3/zip/MiddEval3-GT0-Q.zip
               licence: permission to use and publish; cite the paper.
listed only (no direct public link):
  Middlebury 2001 / 2003 / v2 evaluation (tsukuba, venus, teddy, cones, with nonocc/all masks):
               https://vision.middlebury.edu/stereo/data/ and https://vision.middlebury.edu/stereo/eval/
               cite Scharstein & Szeliski IJCV 2002 (2001) and CVPR 2003 (2003).
  New Tsukuba Stereo Dataset (Martull et al. 2012, 640x480, 1800 frames, PFM GT):
               https://home.cvlab.cs.tsukuba.ac.jp/dataset (request form; research and education use only;
               cite Martull et al. TrackMark 2012 and Peris et al. ICPR 2012).
  FlyingThings3D (Mayer et al., CVPR 2016), research use only, very large:
               https://lmb.informatik.uni-freiburg.de/resources/datasets/SceneFlowDatasets.en.html
EOF
}

if [ $# -eq 0 ]; then
  list_sources
  exit 0
fi
DEST="$1"; shift
SETS=("$@")
[ ${#SETS[@]} -gt 0 ] || SETS=(kitti2012 kitti2015 middlebury2006 middlebury2014 middeval3)
mkdir -p "$DEST"

fetch() {  # fetch URL DIR: download (resumable) and unpack a zip into DIR
  local url="$1" dir="$2" file
  file="$dir/$(basename "$url")"
  mkdir -p "$dir"
  echo "fetch: $url"
  if command -v curl >/dev/null; then
    curl -fL --retry 3 -C - -o "$file" "$url" || { echo "fetch: FAILED $url (see the page above)" >&2; return 1; }
  elif command -v wget >/dev/null; then
    wget -c -O "$file" "$url" || { echo "fetch: FAILED $url (see the page above)" >&2; return 1; }
  else
    echo "fetch: need curl or wget" >&2; exit 1
  fi
  if command -v unzip >/dev/null; then unzip -q -o "$file" -d "$dir"; else echo "fetch: unzip $file yourself"; fi
}

status=0
for set in "${SETS[@]}"; do
  list_sources | sed -n "/^$set /,/^[a-z]/p" | sed '$d'
  case "$set" in
    kitti2012) fetch https://s3.eu-central-1.amazonaws.com/avg-kitti/data_stereo_flow.zip "$DEST/kitti2012" || status=1 ;;
    kitti2015) fetch https://s3.eu-central-1.amazonaws.com/avg-kitti/data_scene_flow.zip "$DEST/kitti2015" || status=1 ;;
    middlebury2006)
      for scene in Cloth3 Reindeer Wood2; do
        fetch "https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/$scene-2views.zip" \
          "$DEST/middlebury2006" || status=1
      done ;;
    middlebury2014)
      fetch https://vision.middlebury.edu/stereo/data/scenes2014/zip/Motorcycle-perfect.zip "$DEST/middlebury2014" || status=1 ;;
    middeval3)
      fetch https://vision.middlebury.edu/stereo/submit3/zip/MiddEval3-data-Q.zip "$DEST/middeval3" || status=1
      fetch https://vision.middlebury.edu/stereo/submit3/zip/MiddEval3-GT0-Q.zip "$DEST/middeval3" || status=1 ;;
    *) echo "fetch_datasets.sh: unknown set '$set' (run without arguments for the list)" >&2; exit 1 ;;
  esac
done
exit $status
