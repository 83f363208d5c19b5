#!/bin/sh
# Build the zenav image without the package index: wheels of zenav and its
# dependencies are built on this host, and the image installs only those.
# Usage: docker/build-image.sh
# Environment: ZENAV_IMAGE (tag, default zenav:latest), ZENAV_BASE (base image,
# default zenav-base:bookworm from docker/build-base-image.sh), PYTHON (the host
# Python that builds the wheels; same version and platform as the base's).
set -eu

IMAGE="${ZENAV_IMAGE:-zenav:latest}"
BASE="${ZENAV_BASE:-zenav-base:bookworm}"
PYTHON="${PYTHON:-python3}"
REPO="$(cd "$(dirname "$0")/.." && pwd)"

# Wheels of compiled dependencies fit one Python version: the host's must be the base's.
version='import sys; print("%d.%d" % sys.version_info[:2])'
host_version="$("$PYTHON" -c "$version")"
base_version="$(docker run --rm --entrypoint python3 "$BASE" -c "$version")"
if [ "$host_version" != "$base_version" ]; then
    echo "$PYTHON is Python $host_version, $BASE has $base_version: set PYTHON to a $base_version" >&2
    exit 1
fi

CTX="$(mktemp -d)"
trap 'rm -rf "$CTX"' EXIT

# Build from a copy so that the checkout gets no build/ or egg-info litter.
mkdir "$CTX/src"
tar -C "$REPO" -c --exclude=./.git --exclude=./tests --exclude=./build --exclude='*.egg-info' \
    --exclude=__pycache__ --exclude=.pytest_cache --exclude=./docker/secure/secrets . | tar -C "$CTX/src" -x
"$PYTHON" -m pip wheel --quiet --disable-pip-version-check --wheel-dir "$CTX/ctx/wheels" "$CTX/src"

cp "$REPO/Dockerfile" "$CTX/ctx/Dockerfile"
docker build --quiet --build-arg BASE="$BASE" --tag "$IMAGE" "$CTX/ctx"
# Drop untagged zenav images: build stages (never reused, the zenav wheel differs
# every build) and the image this tag named before.
docker image prune --force --filter label=zenav.stage >/dev/null
echo "built $IMAGE from $BASE"
