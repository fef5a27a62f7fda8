#!/usr/bin/env bash
# rtk conform runs exactly the profiles an integrator declares, in its
# order, and refuses a declaration with an unknown, misspelt, repeated or
# empty item before any profile runs, naming the item and the known
# profiles. The plugins (profile_declared.c) pass the generic checks and
# fail every exact test, so each run fails; what matters is which
# profiles ran and what was said.
# usage: test_profile_list.sh RTK PLUGIN_DIR
set -u
rtk=$1 dir=$2
known='known: ambient-occlusion, direct-area-light, whitted-recursion, headlight-shading, environment-light, path-tracing'
failed=0
out=
run() { # conform plugin $1; its output in $out; fails when the run passed
    out=$("$rtk" conform "$dir/$1.so" 2>&1)
    local status=$?
    if [ $status -eq 0 ]; then
        echo "FAIL  $1: rtk conform passed; the white integrator must fail a profile's exact tests"
        failed=$((failed + 1))
    fi
}
has() { # $1 is in $out
    if grep -qF -- "$1" <<<"$out"; then echo "ok    $plugin says: $1"; else
        echo "FAIL  $plugin lacks: $1"; failed=$((failed + 1)); fi
}
lacks() { # $1 is not in $out
    if grep -qF -- "$1" <<<"$out"; then echo "FAIL  $plugin says: $1"; failed=$((failed + 1)); else
        echo "ok    $plugin does not say: $1"; fi
}
order() { # the profile lines in $out are exactly $1 (space-separated)
    local ran
    ran=$(grep -E '^# profile [a-z-]+: exact tests$' <<<"$out" | awk '{print $3}' | tr -d ':' | xargs)
    if [ "$ran" = "$1" ]; then echo "ok    $plugin runs the profiles '$1'"; else
        echo "FAIL  $plugin runs the profiles '$ran', expected '$1'"; failed=$((failed + 1)); fi
}

plugin=profile_list # "headlight-shading, ambient-occlusion"
run $plugin
order "headlight-shading ambient-occlusion"
has 'ok    profile "headlight-shading": the plugin has the parameters the profile sets'
has 'ok    profile "ambient-occlusion": the plugin has the parameters the profile sets'
has 'FAIL  foot of an infinite wall:'

plugin=profile_misspelt # "ambient-occlusion,headlight-shadin"
run $plugin
order ""
has 'conform profile "headlight-shadin" is known'
has 'did you mean "headlight-shading"?'
has "$known"
lacks 'conform profile "ambient-occlusion" is known'

plugin=profile_unknown_word # "ambient-occlusion,photon-mapping"
run $plugin
order ""
has 'conform profile "photon-mapping" is known'
has "$known"
lacks 'did you mean'

plugin=profile_repeated # "ambient-occlusion, ambient-occlusion"
run $plugin
order ""
has 'lists "ambient-occlusion" twice'

plugin=profile_empty # "ambient-occlusion,,headlight-shading"
run $plugin
order ""
has 'has an empty item'

plugin=profile_old_name # "ao" in a 3.2 descriptor
run $plugin
order ""
has '"ao" is the ABI 3.1 name of "ambient-occlusion"'

plugin=profile_abi31 # "ao" in a 3.1 descriptor keeps its 3.1 meaning
run $plugin
order "ambient-occlusion"

echo "$failed failed"
[ "$failed" = 0 ]
