#!/usr/bin/env bash
# Installs everything Facecast needs on Debian 12 (run as root). Idempotent: apt and npm skip what is there.
set -euo pipefail
cd "$(dirname "$0")/.."

# What building and serving need (scripts/run.sh installs only these: the first page comes sooner).
packages=(
  build-essential cmake ninja-build pkg-config git ccache
  libboost1.81-dev libeigen3-dev libtinygltf-dev nlohmann-json3-dev libcli11-dev
  libnanoflann-dev libsuitesparse-dev libopenblas0-pthread catch2
  libespeak-ng-dev espeak-ng-data unicode-data rime-data-pinyin-simp libbz2-dev
  libopenimageio-dev libpng-dev libwebp-dev ffmpeg libegl-dev libopengl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri
  fonts-dejavu-core
  libmeshoptimizer-dev libdraco-dev libdlib-dev libdlib-data
  libfftw3-dev libsndfile1-dev
  libpocketsphinx-dev libsphinxbase-dev pocketsphinx-en-us
  libsqlite3-dev libhiredis-dev libjwt-dev libssl-dev liblo-dev
  nodejs
)
# What the tests and benchmarks add: the browser, other synthesizers, the RTMP and Redis servers
# they start, clang for the fuzzers and the ASan+UBSan tree (with its OpenMP), the Python client,
# the CMU dictionary and a word list for the English text-accuracy test, human speech for the
# alignment checks (alsa-utils' spoken channel names, pocketsphinx-testdata's recordings).
test_packages=(
  chromium fonts-wqy-microhei
  festival festvox-kallpc16k flite sox festlex-cmu wamerican
  alsa-utils pocketsphinx-testdata
  nginx libnginx-mod-rtmp redis-server
  clang libclang-rt-14-dev libomp-dev
  python3-websockets
)
serve=0
case ${1:-} in
  --serve) serve=1 ;;
  "") packages+=("${test_packages[@]}") ;;
  *) echo "usage: scripts/install-deps.sh [--serve]" >&2; exit 2 ;;
esac
# Debian's npm conflicts with a nodejs that already bundles npm (the NodeSource build does).
command -v npm >/dev/null 2>&1 || packages+=(npm)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'ok installed' || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "install-deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
# CHOLMOD and dlib call BLAS from several threads at once, which OpenBLAS's pthread build takes and
# its serial build does not (it shares its work buffers between callers without a lock): chosen
# here, also where a serial build is installed and was chosen before.
multiarch=$(dpkg-architecture -qDEB_HOST_MULTIARCH)
for lib in libblas.so.3 liblapack.so.3 libopenblas.so.0; do
  update-alternatives --quiet --set "$lib-$multiarch" "/usr/lib/$multiarch/openblas-pthread/$lib"
done

# Node packages (versions pinned in package-lock.json): serving needs three.js and three-vrm (the
# page's dependencies); the tests' tools are devDependencies.
npm_ci() {
  npm ci --no-audit --no-fund --loglevel=error "$@"
  touch node_modules/.installed"${1:+-serve}"
}
if ((serve)); then
  [ -f node_modules/.installed ] || [ -f node_modules/.installed-serve ] &&
    [ ! package-lock.json -nt node_modules/.package-lock.json ] || npm_ci --omit=dev
  exit 0
fi
[ -f node_modules/.installed ] && [ ! package-lock.json -nt node_modules/.package-lock.json ] || npm_ci

# scikit-image's public-domain test photos (astronaut.png, for the photo-avatar tests): the package
# cannot be installed (its scipy pulls an older Boost), so its .deb is unpacked into a fixed folder.
skimage_dir=/opt/facecast-testdata/python3-skimage
if [ ! -f "$skimage_dir/usr/lib/python3/dist-packages/skimage/data/astronaut.png" ]; then
  tmp=$(mktemp -d)
  (cd "$tmp" && apt-get download python3-skimage >/dev/null 2>&1 ||
    { apt-get update -qq && apt-get download python3-skimage; })
  mkdir -p "$skimage_dir"
  dpkg-deb -x "$tmp"/python3-skimage_*.deb "$skimage_dir"
  rm -rf "$tmp"
fi
