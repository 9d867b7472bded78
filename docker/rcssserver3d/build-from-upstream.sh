#!/usr/bin/env bash
# Build the real RoboCup 3D soccer simulator, rcssserver3d 0.7.3 on SimSpark 0.3.2 (the version
# this project was measured against), from its public upstream release, and install it under a
# prefix. For Debian 12 (bookworm), as root; about 10 minutes on 2 cores.
#
#   sudo bash docker/rcssserver3d/build-from-upstream.sh [PREFIX]      # PREFIX default /opt/rcss
#
# Then:
#   export RCSSSERVER3D=PREFIX/bin/rcssserver3d       # the optimizer's --real N makes its own sync profile
#   PREFIX/bin/rcss-sync --agent-port 3100 --server-port 3200     # or start one in sync mode yourself
#
# NOT RUN END TO END: this script was written on a machine with no internet access beyond package
# registries, so its download step, and with it the build (steps 1-4 below), has never been run.
# Checked there: `bash -n` and shellcheck 0.9.0; the version check and the LOOPBACK_ONLY edits on
# a copy of the same source release; steps 5 and 6 (profile, wrapper, start-up check) against a
# 0.7.3 build made by other means. The upstream URL follows GitLab's archive scheme for the
# project's release tag SIMSPARK_0.3.2_RELEASE (SimSpark 0.3.2 with rcssserver3d 0.7.3); if that
# download fails, the script tries a shallow git clone of the tag, and SIMSPARK_SOURCE=FILE|DIR
# builds from a tarball or source tree you already have.
#
# What it does:
#   1. installs the build dependencies with apt-get (SKIP_APT=1 skips this);
#   2. downloads the release (or takes SIMSPARK_SOURCE), unpacks it into PREFIX/src, and checks
#      that it is SimSpark 0.3.2 / rcssserver3d 0.7.3 (ALLOW_OTHER_VERSION=1 builds another);
#   3. builds and installs SimSpark (spark/, without its Qt GUI "carbon"), then rcssserver3d;
#   4. registers the libraries with ldconfig;
#   5. writes the sync profile (sync mode on, real time off, single-threaded, mypos/myorien/ballpos
#      on, beam noise 0; sync-profile.sh beside this script) into PREFIX/share/rcss-sync-home and
#      the wrapper PREFIX/bin/rcss-sync that runs the server with it;
#   6. starts rcss-sync once on two spare ports, waits until both listen, and stops it again.
#
# Environment: JOBS=N (make -j, default nproc); FORCE=1 (rebuild even if PREFIX holds this build);
# SIMSPARK_REF (release tag, default SIMSPARK_0.3.2_RELEASE); SIMSPARK_URL (the archive's URL);
# SIMSPARK_SHA256 (check the download against it); SIMSPARK_SOURCE (a local .tar.gz/.tar.xz or an
# unpacked tree: no download); LOOPBACK_ONLY=1 (patch the server to listen on 127.0.0.1 only;
# upstream listens on every interface); SKIP_SMOKE=1 (no start-up check).
#
# Why single-threaded: with Ruby 3 (Debian 12 has 3.1) the server's multi-threaded loop crashes
# as soon as a client connects. Why rcss-sync and not a ~/.simspark of your own: the server copies
# spark.rb into ~/.simspark on its first run and that copy wins from then on, so a profile is best
# kept in a HOME of its own. Stopping: SIGTERM and SIGINT only close rcssserver3d's sockets and
# leave it spinning at 100% CPU; send `(killsim)` on the monitor port, or SIGKILL.
set -euo pipefail

PREFIX=${1:-/opt/rcss}
REF=${SIMSPARK_REF:-SIMSPARK_0.3.2_RELEASE}
URL=${SIMSPARK_URL:-https://gitlab.com/robocup-sim/SimSpark/-/archive/$REF/SimSpark-$REF.tar.gz}
GIT_URL=https://gitlab.com/robocup-sim/SimSpark.git
JOBS=${JOBS:-$(nproc)}
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
STAMP=$PREFIX/.gala-nao-built-$REF
SRC=$PREFIX/src/simspark

say() { printf '== %s\n' "$*" >&2; }
fail() { printf 'build-from-upstream: %s\n' "$*" >&2; exit 1; }

case $PREFIX in /*) ;; *) fail "PREFIX must be an absolute path, got '$PREFIX'" ;; esac
for helper in sync-profile.sh listening.sh; do
    [ -f "$HERE/$helper" ] || fail "$helper must lie beside this script (in $HERE)"
done

if [ "${FORCE:-0}" != 1 ] && [ -f "$STAMP" ] && [ -x "$PREFIX/bin/rcss-sync" ]; then
    say "already built in $PREFIX ($REF); FORCE=1 rebuilds"
    exit 0
fi

# ------------------------------------------------------------------------ 1. build dependencies
if [ "${SKIP_APT:-0}" != 1 ]; then
    [ "$(id -u)" = 0 ] || fail "run as root (apt-get), or install the packages yourself and set SKIP_APT=1"
    say "installing the build dependencies (apt-get)"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q
    # ODE 0.16 in double precision, Ruby with headers, Boost, FreeType, DevIL, SDL 1.2 (the one
    # CMake's FindSDL looks for), OpenGL/GLU/GLUT, and Qt 5 with OpenGL: SimSpark builds its Qt
    # plugins even when its GUI is switched off.
    apt-get install -y -q --no-install-recommends \
        build-essential cmake pkg-config curl ca-certificates git xz-utils \
        libode-dev ruby ruby-dev \
        libboost-dev libboost-thread-dev libboost-system-dev libboost-regex-dev \
        libboost-date-time-dev libboost-filesystem-dev \
        libfreetype-dev libdevil-dev libsdl1.2-dev libsdl2-dev libtbb-dev zlib1g-dev \
        libgl-dev libglu1-mesa-dev freeglut3-dev \
        qtbase5-dev qtbase5-dev-tools libqt5opengl5-dev
fi

mkdir -p "$PREFIX/src"
[ -w "$PREFIX" ] || fail "cannot write to $PREFIX"

# ------------------------------------------------------------------------ 2. the source
unpack() { # ARCHIVE: unpack into $SRC, dropping the archive's top folder
    rm -rf "$SRC" && mkdir -p "$SRC"
    tar -xf "$1" -C "$SRC" --strip-components=1
}

if [ -n "${SIMSPARK_SOURCE:-}" ]; then
    if [ -d "$SIMSPARK_SOURCE" ]; then
        say "copying the source tree $SIMSPARK_SOURCE"
        rm -rf "$SRC" && mkdir -p "$SRC"
        cp -a "$SIMSPARK_SOURCE/." "$SRC/"
    else
        [ -f "$SIMSPARK_SOURCE" ] || fail "SIMSPARK_SOURCE=$SIMSPARK_SOURCE is neither a file nor a folder"
        say "unpacking $SIMSPARK_SOURCE"
        unpack "$SIMSPARK_SOURCE"
    fi
else
    archive=$PREFIX/src/SimSpark-$REF.tar.gz
    say "downloading $URL"
    if curl -fL --retry 3 --connect-timeout 30 -o "$archive.part" "$URL"; then
        mv -f "$archive.part" "$archive"
        if [ -n "${SIMSPARK_SHA256:-}" ]; then
            echo "$SIMSPARK_SHA256  $archive" | sha256sum -c - >/dev/null \
                || fail "$archive does not match SIMSPARK_SHA256"
        else
            say "sha256 of the download: $(sha256sum "$archive" | cut -d' ' -f1) (set SIMSPARK_SHA256 to pin it)"
        fi
        unpack "$archive"
    else
        rm -f "$archive.part"
        say "the archive download failed; trying: git clone --depth 1 --branch $REF $GIT_URL"
        rm -rf "$SRC"
        git clone --quiet --depth 1 --branch "$REF" "$GIT_URL" "$SRC" \
            || fail "could not fetch $REF from $URL or $GIT_URL (set SIMSPARK_SOURCE to build from a copy you have)"
    fi
fi

for tree in spark rcssserver3d; do
    [ -f "$SRC/$tree/CMakeLists.txt" ] || fail "$SRC has no $tree/CMakeLists.txt: not a SimSpark source tree"
done

package_version() { # CMAKELISTS: the PACKAGE_VERSION it sets
    sed -n 's/^[[:space:]]*set(PACKAGE_VERSION "\([^"]*\)").*/\1/p' "$1" | head -n 1
}
spark_version=$(package_version "$SRC/spark/CMakeLists.txt")
server_version=$(package_version "$SRC/rcssserver3d/CMakeLists.txt")
say "source: SimSpark $spark_version, rcssserver3d $server_version"
if [ "$spark_version" != 0.3.2 ] || [ "$server_version" != 0.7.3 ]; then
    [ "${ALLOW_OTHER_VERSION:-0}" = 1 ] \
        || fail "expected SimSpark 0.3.2 / rcssserver3d 0.7.3 (what the project was measured on); ALLOW_OTHER_VERSION=1 builds it anyway"
fi

if [ "${LOOPBACK_ONLY:-0}" = 1 ]; then
    say "LOOPBACK_ONLY=1: the server will listen on 127.0.0.1 only"
    net=$SRC/spark/lib/oxygen/simulationserver/netcontrol.cpp
    proxy=$SRC/spark/lib/oxygen/proxyserver/proxyserver.cpp
    sed -i -E 's/(mLocalAddr[[:space:]]*=[[:space:]]*Addr\(INADDR_ANY,[[:space:]]*)INADDR_ANY\)/\1INADDR_LOOPBACK) \/* gala-nao: loopback only *\//' "$net"
    sed -i -E 's/mLocalAddr\(0,[[:space:]]*Addr::ANY\)/mLocalAddr(0, INADDR_LOOPBACK) \/* gala-nao: loopback only *\//' "$proxy"
    grep -q 'include <netinet/in.h>' "$proxy" || sed -i '0,/^#include/s//#include <netinet\/in.h>\n#include/' "$proxy"
    [ "$(grep -c 'gala-nao: loopback only' "$net" "$proxy" | awk -F: '{ n += $2 } END { print n }')" = 2 ] \
        || fail "the loopback edit did not apply to $net and $proxy (another source version?)"
fi

# ------------------------------------------------------------------------ 3. build and install
build() { # NAME DIR CMAKE_ARGS...: configure, build and install one tree; logs in DIR/build
    local name=$1 dir=$2
    shift 2
    say "building $name (make -j$JOBS; logs in $dir/build)"
    mkdir -p "$dir/build"
    # CMAKE_POLICY_VERSION_MINIMUM: the trees ask for CMake 2.6, which CMake 4 refuses without it
    # (older CMake ignores the setting).
    (cd "$dir/build" \
        && cmake .. -DCMAKE_INSTALL_PREFIX="$PREFIX" -DCMAKE_BUILD_TYPE=Release \
            -DCMAKE_POLICY_VERSION_MINIMUM=3.5 "$@" >cmake.log 2>&1) \
        || { tail -n 30 "$dir/build/cmake.log" >&2; fail "configuring $name failed"; }
    (cd "$dir/build" && make -j"$JOBS" >make.log 2>&1) \
        || { tail -n 40 "$dir/build/make.log" >&2; fail "building $name failed"; }
    (cd "$dir/build" && make install >install.log 2>&1) \
        || { tail -n 20 "$dir/build/install.log" >&2; fail "installing $name failed"; }
}

# SimSpark first; its Qt GUI (carbon) is not needed by the server.
build SimSpark "$SRC/spark" -DBUILD_CARBON=OFF
# rcssserver3d finds SimSpark through SPARK_DIR and the prefix path.
SPARK_DIR=$PREFIX build rcssserver3d "$SRC/rcssserver3d" -DCMAKE_PREFIX_PATH="$PREFIX"
[ -x "$PREFIX/bin/rcssserver3d" ] || fail "no $PREFIX/bin/rcssserver3d after installing"

# ------------------------------------------------------------------------ 4. shared libraries
if [ "$(id -u)" = 0 ] && [ -d /etc/ld.so.conf.d ]; then
    say "registering $PREFIX/lib/simspark and $PREFIX/lib/rcssserver3d with ldconfig"
    printf '%s\n' "$PREFIX/lib/simspark" "$PREFIX/lib/rcssserver3d" \
        >"/etc/ld.so.conf.d/gala-nao-rcss-$(echo "$PREFIX" | tr '/' '_').conf"
    ldconfig
else
    say "not root: run the server through rcss-sync, or add $PREFIX/lib/simspark and $PREFIX/lib/rcssserver3d to LD_LIBRARY_PATH"
fi

# ------------------------------------------------------------------------ 5. sync profile and wrapper
# The server reads its scripts from the working directory, then ~/.simspark, then its install's
# share folders. The profile is a HOME of its own: PREFIX/share/rcss-sync-home/.simspark holding
# edited copies of the four files the profile changes (and kerosin.rb unchanged, which the server
# would otherwise try to copy there itself at start-up).
share=$PREFIX/share
home=$share/rcss-sync-home
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/simspark" "$stage/rcssserver3d/rsg/agent/nao"
for f in simspark/spark.rb simspark/kerosin.rb rcssserver3d/rcssserver3d.rb \
    rcssserver3d/naosoccersim.rb rcssserver3d/rsg/agent/nao/naoneckhead.rsg; do
    [ -f "$share/$f" ] || fail "the install has no $share/$f"
    cp "$share/$f" "$stage/$f"
done
sh "$HERE/sync-profile.sh" "$stage" >&2
mkdir -p "$home/.simspark/rsg/agent/nao"
cp "$stage/simspark/spark.rb" "$stage/simspark/kerosin.rb" "$home/.simspark/"
cp "$stage/rcssserver3d/rcssserver3d.rb" "$stage/rcssserver3d/naosoccersim.rb" "$home/.simspark/"
cp "$stage/rcssserver3d/rsg/agent/nao/naoneckhead.rsg" "$home/.simspark/rsg/agent/nao/"

cat >"$PREFIX/bin/rcss-sync" <<EOF
#!/bin/sh
# rcss-sync: rcssserver3d $server_version in the sync profile (sync mode on, real time off,
# single-threaded, mypos/myorien/ballpos on, beam noise 0), made by build-from-upstream.sh.
# Usage: rcss-sync [rcssserver3d options], e.g. rcss-sync --agent-port 3100 --server-port 3200
# It replaces itself with the server (same PID). Stop it with (killsim) on the monitor port, or
# SIGKILL: SIGTERM only closes its sockets. RCSS_SYNC_HOME=DIR runs it with DIR/.simspark instead.
PREFIX='$PREFIX'
EOF
cat >>"$PREFIX/bin/rcss-sync" <<'EOF'
HOME=${RCSS_SYNC_HOME:-$PREFIX/share/rcss-sync-home}
export HOME
unset SPARK_DIR    # it would send the server's share/ lookup away from PREFIX
LD_LIBRARY_PATH=$PREFIX/lib/simspark:$PREFIX/lib/rcssserver3d${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export LD_LIBRARY_PATH
cd "$HOME" || exit 1   # scripts in the working directory would win over the profile's
exec "$PREFIX/bin/rcssserver3d" "$@"
EOF
chmod 0755 "$PREFIX/bin/rcss-sync"

# ------------------------------------------------------------------------ 6. does it start?
if [ "${SKIP_SMOKE:-0}" != 1 ]; then
    agent_port=${SMOKE_AGENT_PORT:-31100}
    monitor_port=${SMOKE_MONITOR_PORT:-31200}
    if sh "$HERE/listening.sh" "$agent_port" 2>/dev/null || sh "$HERE/listening.sh" "$monitor_port" 2>/dev/null; then
        say "ports $agent_port/$monitor_port are taken: start-up check skipped (SMOKE_AGENT_PORT, SMOKE_MONITOR_PORT)"
    else
        say "start-up check: rcss-sync on ports $agent_port/$monitor_port"
        log=$stage/smoke.log
        "$PREFIX/bin/rcss-sync" --agent-port "$agent_port" --server-port "$monitor_port" >"$log" 2>&1 &
        pid=$!
        up=0
        for _ in $(seq 150); do
            if sh "$HERE/listening.sh" "$agent_port" "$monitor_port" 2>/dev/null; then up=1; break; fi
            kill -0 "$pid" 2>/dev/null || break
            sleep 0.2
        done
        # (killsim) on the monitor port: a 4-byte big-endian length, then the message.
        if [ $up = 1 ]; then
            { printf '\000\000\000\011(killsim)' >"/dev/tcp/127.0.0.1/$monitor_port"; } 2>/dev/null || true
        fi
        for _ in $(seq 20); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$pid" 2>/dev/null || true
        wait "$pid" 2>/dev/null || true
        [ $up = 1 ] || { tail -n 30 "$log" >&2; fail "the server did not open ports $agent_port and $monitor_port"; }
        say "start-up check passed"
    fi
fi

touch "$STAMP"
cat >&2 <<EOF
== rcssserver3d $server_version (SimSpark $spark_version) is installed in $PREFIX.

Use it with this project:
    export RCSSSERVER3D=$PREFIX/bin/rcssserver3d
    python -m optimizer.episode --real 1 --repeat 10

Start one yourself in sync mode (it steps once every agent has sent (syn), as fast as they answer):
    $PREFIX/bin/rcss-sync --agent-port 3100 --server-port 3200
    python -m agent --sync --beam -1 0 0 --start-now --duration 15

Stop a server with (killsim) on its monitor port, or SIGKILL (SIGTERM leaves it spinning).
EOF
