#!/bin/sh
# Build a local Debian bookworm base image with python3 and venv, without a
# registry: debootstrap a minimal root and `docker import` it.
# Usage: docker/build-base-image.sh [image tag]   (default zenav-base:bookworm)
# Environment: ZENAV_DEBIAN_MIRROR (default: the first deb.debian.org-style URI
# apt uses here, else http://deb.debian.org/debian). Needs root; installs
# debootstrap with apt-get when it is missing.
set -eu

IMAGE="${1:-zenav-base:bookworm}"
SUITE=bookworm
PACKAGES=python3,python3-venv,ca-certificates

if docker image inspect "$IMAGE" >/dev/null 2>&1; then
    echo "$IMAGE exists"
    exit 0
fi

mirror_from_apt() {
    # First "URIs:" (deb822) or "deb" line pointing at a Debian archive.
    cat /etc/apt/sources.list /etc/apt/sources.list.d/*.sources /etc/apt/sources.list.d/*.list 2>/dev/null \
        | sed -n -e 's/^URIs:[[:space:]]*\([^[:space:]]*\/debian\)[[:space:]]*$/\1/p' \
                 -e 's/^deb[[:space:]]\+\(\[[^]]*\][[:space:]]\+\)\?\([^[:space:]]*\/debian\)[[:space:]]\+bookworm[[:space:]].*/\2/p' \
        | head -n 1
}
MIRROR="${ZENAV_DEBIAN_MIRROR:-$(mirror_from_apt)}"
MIRROR="${MIRROR:-http://deb.debian.org/debian}"

if ! command -v debootstrap >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "installing debootstrap"
        apt-get update -qq && apt-get install -y -qq debootstrap >/dev/null
    else
        echo "debootstrap is missing: apt-get install debootstrap (as root)" >&2
        exit 1
    fi
fi

CACHE="${XDG_CACHE_HOME:-$HOME/.cache}/zenav"
mkdir -p "$CACHE"
ROOT="$(mktemp -d "$CACHE/rootfs.XXXXXX")"
trap 'rm -rf "$ROOT"' EXIT

echo "debootstrap $SUITE from $MIRROR into $ROOT"
debootstrap --variant=minbase --include="$PACKAGES" "$SUITE" "$ROOT" "$MIRROR"
# Keep the image small: no package lists, caches or docs.
rm -rf "$ROOT"/var/lib/apt/lists/* "$ROOT"/var/cache/apt/*.bin "$ROOT"/var/cache/apt/archives/*.deb \
       "$ROOT"/usr/share/doc/* "$ROOT"/usr/share/man/* "$ROOT"/usr/share/info/*

tar -C "$ROOT" -c . | docker import \
    --change 'ENV LANG=C.UTF-8' \
    --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
    --change 'CMD ["python3"]' \
    - "$IMAGE"
echo "built $IMAGE"
