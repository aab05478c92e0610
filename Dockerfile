# The live twin for demos: landing page and REST API on 8000, the 3D viewer on 8080.
#   docker build -t wave-twin .
#   TWIN_TOKEN=$(openssl rand -hex 16); echo "token: $TWIN_TOKEN"
#   docker run --rm -p 8000:8000 -p 8080:8080 -e TWIN_TOKEN=$TWIN_TOKEN wave-twin
# TWIN_TOKEN (≥ 16 characters) is required: bound to 0.0.0.0, the server refuses to start
# without one (POST and PATCH then need `Authorization: Bearer $TWIN_TOKEN`; browsers unlock
# the viewer's controls). Browse it as localhost:8000 / :8080; under another name or port add
# e.g. `--allow-host twin.example.com --allow-origin http://twin.example.com:9000` to the CMD.
# Runs are stored in /home/twin/data (a volume: mount it to keep them; one server at a time).
# `docker stop` (SIGTERM) stops it within seconds; unfinished runs stay queued.
# The base image pinned by digest, so a rebuild gets the same Python and Debian as the last one.
# python:3.11-slim-bookworm as Docker Hub served it on 2026-08-24 (amd64/arm64 index digest). No
# registry is reachable from our machines: the digest was found in a public repository's
# architecture record dated that day, which states it was rechecked against Docker Hub's manifest
# then. To refresh it (see `make lock`): `docker buildx imagetools inspect
# python:3.11-slim-bookworm` prints the current digest; put it and today's date here.
FROM python:3.11-slim-bookworm@sha256:2e32f7d302adc1c37428355c1e646897c0c53f4fd60b6a551245fb90ee129f91

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1

WORKDIR /src
# The locked dependency set (requirements/serve.txt: exact versions with hashes, `make lock`),
# then the package alone: the image runs what CI tested.
COPY requirements/serve.txt ./requirements/
COPY pyproject.toml README.md ./
COPY twin ./twin
COPY assets ./assets
COPY static ./static
RUN pip install --require-hashes -r requirements/serve.txt && pip install --no-deps . && rm -rf /src

RUN useradd --create-home --uid 10001 twin
USER twin
WORKDIR /home/twin
# Created as the user so a fresh named volume inherits its ownership.
RUN mkdir data
# The compiled kernels, built once into the image's numba cache: a container starts in seconds.
ENV NUMBA_CACHE_DIR=/home/twin/.numba
RUN python -c "from twin.sim.engine import warm; print(f'kernels compiled in {warm():.0f} s')"
VOLUME ["/home/twin/data"]

EXPOSE 8000 8080
HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/api/health', timeout=4)"]
CMD ["twin", "serve", "--host", "0.0.0.0"]
