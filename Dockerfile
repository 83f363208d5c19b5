# One image for the whole stack: the router and every service.
#   docker compose build                      (base: the public Python image)
#   docker/build-image.sh                     (offline: local base, wheels from the host)
# The build context is either this checkout (installed from the package index)
# or a directory holding wheels/ (zenav and its dependencies; installed offline).
ARG BASE=python:3.11-slim

FROM ${BASE} AS build
LABEL zenav.stage=build
COPY . /src
RUN python3 -m venv /opt/zenav \
    && if [ -d /src/wheels ]; then \
           /opt/zenav/bin/pip install --no-cache-dir --disable-pip-version-check --no-index --find-links /src/wheels zenav; \
       else \
           /opt/zenav/bin/pip install --no-cache-dir --disable-pip-version-check /src; \
       fi \
    && /opt/zenav/bin/pip uninstall --yes --quiet pip setuptools

FROM ${BASE}
LABEL zenav.stage=final
RUN useradd --system --user-group --uid 10001 --home-dir /nonexistent --shell /usr/sbin/nologin zenav
COPY --from=build /opt/zenav /opt/zenav
ENV PATH=/opt/zenav/bin:$PATH \
    PYTHONUNBUFFERED=1 \
    PYTHONDONTWRITEBYTECODE=1
USER zenav
EXPOSE 7447
CMD ["zenav", "--help"]
