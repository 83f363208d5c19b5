#!/bin/sh
# Build the zenav image where a build cannot reach the package index (no registry, or
# a proxy the build's containers do not trust): the wheels of zenav's dependencies
# are downloaded on this host into an image of their own, and compose builds the
# image from this checkout with them (`docker compose build`, the Dockerfile's WHEELS);
# zenav itself is built inside the build from the context compose sends.
# Usage: docker/build-image.sh
# Environment: ZENAV_IMAGE (tag, default zenav:latest), ZENAV_BASE (base image,
# default zenav-base:bookworm from docker/build-base-image.sh), ZENAV_EXTRAS (the
# Dockerfile's EXTRAS, default auto), ZENAV_WHEELS (tag of the wheels' image, default
# zenav-wheels:latest), PYTHON (the host Python whose pip downloads the wheels, any
# version: they are chosen for the base's Python and platform).
set -eu

IMAGE="${ZENAV_IMAGE:-zenav:latest}"
BASE="${ZENAV_BASE:-zenav-base:bookworm}"
EXTRAS="${ZENAV_EXTRAS:-auto}"
WHEELS="${ZENAV_WHEELS:-zenav-wheels:latest}"
PYTHON="${PYTHON:-python3}"
REPO="$(cd "$(dirname "$0")/.." && pwd)"

if docker compose version >/dev/null 2>&1; then
    compose="docker compose"
elif command -v docker-compose >/dev/null 2>&1; then
    compose=docker-compose
else
    echo "neither \`docker compose\` nor \`docker-compose\` is installed" >&2
    exit 1
fi

# The base's Python version, machine and C library: the wheels must fit them.
set -- $(docker run --rm --entrypoint python3 "$BASE" -c \
    'import platform, sys; print("%d.%d" % sys.version_info[:2], platform.machine(), platform.libc_ver()[1])')
version=$1 machine=$2 glibc=$3
platforms="--platform manylinux2014_$machine"
minor=17
while [ "$minor" -le "${glibc#2.}" ]; do
    platforms="$platforms --platform manylinux_2_${minor}_$machine"
    minor=$((minor + 1))
done

CTX="$(mktemp -d)"
trap 'rm -rf "$CTX"' EXIT

# zenav's dependencies with the extras the Dockerfile installs (not zenav: the build makes it).
"$PYTHON" - "$REPO/pyproject.toml" "$EXTRAS" "$machine" > "$CTX/requirements.txt" <<'PY'
import sys

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

with open(sys.argv[1], "rb") as f:
    project = tomllib.load(f)["project"]
extras, machine = sys.argv[2], sys.argv[3]
if extras == "auto":  # as the Dockerfile's
    extras = "camera,robot" + (",apriltag" if machine == "x86_64" else "")
requirements, todo, seen = list(project["dependencies"]), extras.split(","), set()
while todo:
    extra = todo.pop()
    if extra and extra not in seen:
        seen.add(extra)
        for req in project["optional-dependencies"][extra]:
            if req.startswith("zenav["):
                todo += req[len("zenav[") : req.index("]")].split(",")
            else:
                requirements.append(req)
print("\n".join(requirements))
PY
echo "setuptools>=77" >> "$CTX/requirements.txt"  # zenav's build backend
# shellcheck disable=SC2086
"$PYTHON" -m pip download --quiet --disable-pip-version-check --dest "$CTX/wheels" --only-binary :all: \
    --implementation cp --python-version "$version" $platforms --requirement "$CTX/requirements.txt"

printf 'FROM %s\nCOPY wheels /wheels\n' "$BASE" > "$CTX/Dockerfile"
docker build --quiet --tag "$WHEELS" "$CTX" >/dev/null
ZENAV_IMAGE="$IMAGE" ZENAV_BASE="$BASE" ZENAV_WHEELS="$WHEELS" ZENAV_EXTRAS="$EXTRAS" \
    $compose --file "$REPO/docker-compose.yml" build router
# Drop the image this tag named before (the build stages stay: they are the layer cache).
docker image prune --force --filter label=zenav.stage=final >/dev/null
echo "built $IMAGE from $BASE with the wheels of $WHEELS"
