#!/usr/bin/env bash
# Builds the image of `Containerfile` with podman, then runs the pinned quickstart campaign inside
# it (the repository mounted at /data, as `soig k8s` mounts its volume) and checks that the image's
# soig gives the pinned digest (results/ci-quickstart/digest.txt), YOLO stage included.
#
# The machines CI runs on reach Debian's mirror, crates.io and PyPI, but not Docker Hub, so the
# two base images the Containerfile names by default are made here from Debian's packages and
# passed as build arguments: `debian:bookworm-slim` as a debootstrap of bookworm, and
# `rust:1.95-bookworm` as the same plus gcc, make and this machine's Rust 1.95 toolchain. Everything
# after the FROM lines is the Containerfile as a user builds it.
#
#   bash scripts/container-test.sh      (as root: it installs podman, runc and debootstrap)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
pinned=$(cat results/ci-quickstart/digest.txt)

missing=()
for tool in podman runc debootstrap; do command -v "$tool" >/dev/null || missing+=("$tool"); done
if [ ${#missing[@]} -gt 0 ]; then
  echo "container-test: installing ${missing[*]}"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# About 6 GB of disk at the peak (the two base images, the build stage's target/, the image);
# say so up front rather than fail half-way with ENOSPC.
free_kb=$(df -Pk /tmp /var/lib 2>/dev/null | awk 'NR>1 {print $4}' | sort -n | head -1)
if [ "${free_kb:-0}" -lt $((6 * 1024 * 1024)) ]; then
  echo "container-test: needs about 6 GB free in /tmp and /var/lib/containers; has $((free_kb / 1024)) MB" >&2
  exit 1
fi

work=$(mktemp -d /tmp/soig-container.XXXXXX)
images="localhost/soig:ci localhost/soig-ci/rust:1.95-bookworm localhost/soig-ci/debian:bookworm-slim"
# Whatever happens, leave no tree, image or build layer behind (a failed build's layers are
# gigabytes that the next run would not reuse).
# (The tree last: podman reads its configuration from it.)
cleanup() {
  # shellcheck disable=SC2086
  podman rmi -f $images >/dev/null 2>&1 || true
  podman image prune -f >/dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT
# podman's defaults ask for more open files and processes than this machine lets root raise
# (no CAP_SYS_RESOURCE), and crun refuses its hybrid cgroups; runc with limits below the hard
# ones runs.
cat >"$work/containers.conf" <<EOF
[containers]
default_ulimits = ["nofile=4096:4096", "nproc=4096:4096"]
[engine]
runtime = "runc"
EOF
export CONTAINERS_CONF=$work/containers.conf

# The two base images, from Debian's packages (see above). A site whose traffic passes a proxy
# with its own certificate authority puts that authority in its base images; so do these, with
# this machine's (/usr/local/share/ca-certificates), and they tell pip and cargo to use the
# system's bundle. The Containerfile's `apt-get install ca-certificates` then trusts it too.
mirror=http://deb.debian.org/debian
site_ca() {
  mkdir -p "$1/usr/local/share/ca-certificates"
  cp /usr/local/share/ca-certificates/*.crt "$1/usr/local/share/ca-certificates/" 2>/dev/null || true
}
bundle=/etc/ssl/certs/ca-certificates.crt
debootstrap --variant=minbase bookworm "$work/slim" "$mirror" >"$work/slim.log" 2>&1 \
  || { tail -20 "$work/slim.log"; exit 1; }
site_ca "$work/slim"
tar -C "$work/slim" -c . | podman import -q --change "ENV PIP_CERT=$bundle" \
  - localhost/soig-ci/debian:bookworm-slim >/dev/null
debootstrap --variant=minbase --include=gcc,g++,libc6-dev,make,pkg-config,ca-certificates \
  bookworm "$work/rust" "$mirror" >"$work/rust.log" 2>&1 || { tail -20 "$work/rust.log"; exit 1; }
site_ca "$work/rust"
chroot "$work/rust" update-ca-certificates >/dev/null 2>&1
sysroot=$(rustc --print sysroot)
case "$(rustc --version)" in
  "rustc 1.95."*) ;;
  *) echo "container-test: the Containerfile builds with Rust 1.95; this machine has $(rustc --version)" >&2; exit 1 ;;
esac
mkdir -p "$work/rust/usr/local/rust"
# The toolchain without its HTML docs (800 MB that a build never reads).
tar -C "$sysroot" --exclude=./share/doc -c . | tar -C "$work/rust/usr/local/rust" -x
tar -C "$work/rust" -c . | podman import -q \
  --change "ENV PATH=/usr/local/rust/bin:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin" \
  --change "ENV CARGO_HTTP_CAINFO=$bundle" \
  - localhost/soig-ci/rust:1.95-bookworm >/dev/null
rm -rf "$work/slim" "$work/rust"

echo "container-test: podman build (cargo build --release inside; several minutes)"
podman build -q --force-rm -t localhost/soig:ci -f Containerfile \
  --build-arg RUST_IMAGE=localhost/soig-ci/rust:1.95-bookworm \
  --build-arg BASE_IMAGE=localhost/soig-ci/debian:bookworm-slim . >"$work/build.log" 2>&1 \
  || { tail -40 "$work/build.log"; exit 1; }

# The image's default command is `soig --help`; then the quickstart, written inside the container.
# (Captured, not piped into `grep -q`: under pipefail, grep's early exit can kill podman with
# SIGPIPE mid-write and fail a good image; that is how CI failed at 2026-11-26 20:40.)
usage=$(podman run --rm localhost/soig:ci 2>&1) \
  || { echo "container-test: 'soig --help' in the image failed:" >&2; echo "$usage" | tail -20 >&2; exit 1; }
case "$usage" in
  *"Usage: soig"*) ;;
  *) echo "container-test: 'soig --help' in the image printed no usage:" >&2; echo "$usage" | tail -20 >&2; exit 1 ;;
esac
digest=$(podman run --rm -v "$root":/data:ro localhost/soig:ci sh -c \
  'soig run campaigns/quickstart.toml --out /tmp/q --quiet >/dev/null && soig verify /tmp/q' \
  | sed -n 's/.*digest //p')
if [ "$digest" != "$pinned" ]; then
  echo "container-test: the image's quickstart digest is '$digest', pinned $pinned" >&2
  exit 1
fi
echo "container-test: the image's soig gives the pinned quickstart digest $digest"
