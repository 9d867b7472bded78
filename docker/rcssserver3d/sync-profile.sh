#!/bin/sh
# Apply the "sync profile" (tests/data/rcssserver3d/README.md) to the scripts that the
# rcssserver3d/simspark packages installed, at image build time.
#
# Why edit the installed scripts instead of shipping a ~/.simspark overlay: an overlay would be
# full copies of upstream files (their text, not ours) that go stale the day the package changes.
# Editing six values in place keeps everything else exactly as packaged. spark.rb is copied into
# ~/.simspark on the server's first run and that copy wins afterwards; the image never ran the
# server before this edit, so the copy it makes is of the edited file.
#
# Every edit is checked afterwards: if a package release renames or reshapes a setting, the
# build fails here, naming the file and the setting, instead of producing a server that silently
# runs in real time or with beam noise.
#
# Usage: sync-profile.sh [SHARE_DIR ...]   (default: /usr/share /usr/local/share)
set -eu

roots=${*:-/usr/share /usr/local/share}

die() {
    echo "sync-profile: $*" >&2
    exit 1
}

# The one installed file at RELATIVE_PATH under the share folders (e.g. simspark/spark.rb).
locate() {
    # shellcheck disable=SC2086  # $roots is a list of folders on purpose
    found=$(for root in $roots; do if [ -f "$root/$1" ]; then echo "$root/$1"; fi; done)
    [ -n "$found" ] || die "$1 not found under: $roots"
    [ "$(echo "$found" | wc -l)" -eq 1 ] || die "$1 found more than once: $found"
    echo "$found"
}

# Ruby global assignment `$NAME = VALUE` (any spacing, a trailing comment kept).
set_global() { # FILE NAME VALUE
    sed -E -i "s/^([[:space:]]*\\\$$2[[:space:]]*=[[:space:]]*)[^[:space:]#]+/\\1$3/" "$1"
    grep -Eq "^[[:space:]]*\\\$$2[[:space:]]*=[[:space:]]*$3([[:space:]]|#|\$)" "$1" \
        || die "$1: no assignment '\$$2 = ...' to set to $3"
    if grep -E "^[[:space:]]*\\\$$2[[:space:]]*=" "$1" | grep -Evq "=[[:space:]]*$3([[:space:]]|#|\$)"; then
        die "$1: '\$$2' is still assigned another value"
    fi
}

# RSG call `(NAME false)` -> `(NAME true)`.
enable_rsg_flag() { # FILE NAME
    sed -E -i "s/\\(($2)[[:space:]]+false[[:space:]]*\\)/(\\1 true)/" "$1"
    grep -Eq "\\($2[[:space:]]+true[[:space:]]*\\)" "$1" || die "$1: no '($2 true|false)' call"
    if grep -Eq "\\($2[[:space:]]+false" "$1"; then die "$1: '($2 false)' is left"; fi
}

# Soccer variable `addSoccerVar('NAME', NUMBER)` -> NUMBER 0.
zero_soccer_var() { # FILE NAME
    sed -E -i "s/(addSoccerVar\\([[:space:]]*'$2'[[:space:]]*,[[:space:]]*)[-+0-9.eE]+/\\10/" "$1"
    grep -Eq "addSoccerVar\\([[:space:]]*'$2'[[:space:]]*,[[:space:]]*0[[:space:]]*\\)" "$1" \
        || die "$1: no addSoccerVar('$2', ...) to set to 0"
}

spark_rb=$(locate simspark/spark.rb)
server_rb=$(locate rcssserver3d/rcssserver3d.rb)
soccer_rb=$(locate rcssserver3d/naosoccersim.rb)
vision_rsg=$(locate rcssserver3d/rsg/agent/nao/naoneckhead.rsg)

# Step only once every agent has sent (syn); no wall-clock pacing.
set_global "$spark_rb" agentSyncMode true
set_global "$server_rb" enableRealTimeMode false
# Single-threaded loop: with Ruby 3 the multi-threaded one crashes when a monitor connects.
set_global "$spark_rb" serverMultiThreadedMode false
set_global "$spark_rb" threadedAgentControl false
# Ground truth in every vision message: mypos, myorien, ballpos.
enable_rsg_flag "$vision_rsg" setSenseMyPos
enable_rsg_flag "$vision_rsg" setSenseMyOrien
enable_rsg_flag "$vision_rsg" setSenseBallPos
# A beam lands exactly where asked.
zero_soccer_var "$soccer_rb" BeamNoiseXY
zero_soccer_var "$soccer_rb" BeamNoiseAngle

echo "sync-profile: applied to $spark_rb $server_rb $soccer_rb $vision_rsg"
