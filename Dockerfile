# One image for the whole stack: the router and every service.
#   docker compose build                      (base: the public Python image; dependencies from the package index)
#   docker/build-image.sh                     (no package index: the dependencies' wheels downloaded on the host)
# The context is this checkout (.dockerignore keeps the package: pyproject.toml,
# README.md, LICENSE, zenav/). Build arguments:
#   BASE    the base image (a Debian with python3 and its venv module)
#   EXTRAS  the extras installed with zenav; `auto` (the default): camera (OpenCV),
#           robot (pyserial), and apriltag where pupil-apriltags has a wheel (x86-64)
#   WHEELS  an image whose /wheels holds every dependency's wheel: installed from
#           there, offline (docker/build-image.sh makes one); empty: the package index
ARG BASE=python:3.11-slim
ARG WHEELS=

FROM ${WHEELS:-${BASE}} AS wheels
RUN mkdir -p /wheels

# The dependencies in a venv, from pyproject.toml alone (and the version in zenav/__init__.py):
# a change to the rest of the source builds on these layers.
FROM ${BASE} AS deps
LABEL zenav.stage=build
ARG EXTRAS=auto
COPY --from=wheels /wheels /wheels
COPY pyproject.toml /deps/
COPY zenav/__init__.py /deps/zenav/
RUN set -e; \
    extras="$EXTRAS"; \
    if [ "$extras" = auto ]; then \
        extras=camera,robot; \
        if [ "$(uname -m)" = x86_64 ]; then extras="$extras,apriltag"; fi; \
    fi; \
    if [ -n "$(ls /wheels)" ]; then export PIP_NO_INDEX=1 PIP_FIND_LINKS=/wheels; fi; \
    touch /deps/README.md; \
    python3 -m venv /opt/zenav; \
    /opt/zenav/bin/pip install --no-cache-dir --disable-pip-version-check "setuptools>=77" "/deps[$extras]"; \
    /opt/zenav/bin/pip uninstall --yes --quiet zenav

# zenav's wheel, from the context: nothing is fetched.
FROM deps AS build
COPY . /src
RUN /opt/zenav/bin/pip wheel --quiet --no-cache-dir --disable-pip-version-check --no-index --no-build-isolation --no-deps --wheel-dir /dist /src

FROM ${BASE}
LABEL zenav.stage=final
# dialout: the serial port of a motor board passed in as a device (the robot profile)
RUN useradd --system --user-group --groups dialout --uid 10001 --home-dir /nonexistent --shell /usr/sbin/nologin zenav \
    && install --directory --owner zenav --group zenav /var/log/zenav  # `zenav up`'s logs (the robot profile's volume)
COPY --from=deps /opt/zenav /opt/zenav
COPY --from=build /dist /dist
RUN /opt/zenav/bin/pip install --quiet --no-cache-dir --disable-pip-version-check --no-index --no-deps /dist/*.whl \
    && /opt/zenav/bin/pip check --disable-pip-version-check \
    && rm -rf /dist
ENV PATH=/opt/zenav/bin:$PATH \
    PYTHONUNBUFFERED=1 \
    PYTHONDONTWRITEBYTECODE=1
USER zenav
EXPOSE 7447
CMD ["zenav", "--help"]
