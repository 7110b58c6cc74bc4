# drapery: the simulation service in a small image.
#
#   docker build -t drapery .
#   docker run -p 8080:8080 -v drapery-data:/data drapery
#
# Several nodes on one PostgreSQL: compose.yaml. scripts/container-check
# builds and runs this file with podman in CI.
#
# Build stage: the toolchain the project pins (rust-version 1.85+; CI uses
# 1.95). The bundled SQLite needs the C compiler the rust image carries.
FROM rust:1.95-slim-bookworm AS build
WORKDIR /src
COPY Cargo.toml Cargo.lock ./
COPY sim sim
COPY studies studies
COPY src src
COPY benches benches
COPY api api
COPY viewer viewer
COPY examples examples
ENV CARGO_PROFILE_RELEASE_DEBUG=0 \
    CARGO_PROFILE_RELEASE_STRIP=true
RUN cargo build --release --locked --bin drapery

# Run stage: glibc only, no toolchain, no shell tools needed.
FROM debian:bookworm-slim
RUN useradd --system --uid 10001 --create-home --home-dir /home/drapery drapery \
    && mkdir /data \
    && chown drapery:drapery /data
COPY --from=build /src/target/release/drapery /usr/local/bin/drapery
COPY examples/scenes /usr/share/drapery/scenes
USER 10001:10001
ENV DRAPERY_ADDR=0.0.0.0:8080 \
    DRAPERY_DATA=/data \
    DRAPERY_LOG_JSON=true \
    DRAPERY_HEALTH_ADDR=127.0.0.1:8080
VOLUME ["/data"]
EXPOSE 8080
HEALTHCHECK --interval=15s --timeout=5s --start-period=10s --retries=3 \
    CMD ["drapery", "health"]
# SIGTERM (docker stop) checkpoints running jobs; give it the grace period.
STOPSIGNAL SIGTERM
ENTRYPOINT ["drapery"]
CMD ["serve"]
