#!/bin/sh
# make bench-full: every row of the cost table and every study, one step after another.
# Before it starts it prints the steps and about how long each will take on this machine
# (the last run's seconds, kept in the bake cache's folder, or a 2-core lavapipe machine's
# with none); before each step, the time left.
#
# Environment: SHVIS (the binary), OUT (the output folder), RNM_ENVS, NDF_ENVS, MODEL_ARG
# (the shared assets' probe and model where present), NMPRT_ROWS, BASES_ENVS, ENGINE_SH_ENV,
# ENGINE_SH_ROWS.
set -eu
SHVIS=${SHVIS:-target/release/shvis}
OUT=${OUT:-bench-out}
CACHE=${SHVIS_CACHE_DIR:-.shvis-cache}
TIMES="$CACHE/bench-full-seconds.txt"
mkdir -p "$CACHE"

# name|seconds on a 2-core lavapipe machine (measured there)|command
steps() {
    cat <<STEPS
bench|950|$SHVIS bench --techniques all --out $OUT
bench dx11|480|$SHVIS bench --techniques all --paths dx11 --frames 5 --warmup 1 --out $OUT/dx11
study rnm|60|$SHVIS study rnm --envs $RNM_ENVS --out $OUT/rnm
study normalmap|75|$SHVIS study normalmap $MODEL_ARG --out $OUT/normalmap
study ndf|40|$SHVIS study ndf --diffuse-envs $NDF_ENVS --out $OUT/ndf
study nmprt-svd|5|$SHVIS study nmprt-svd --out $OUT/nmprt
study bases|40|$SHVIS study bases --envs $BASES_ENVS --out $OUT/bases
study rays|110|$SHVIS study rays --out $OUT/rays
bench engine-sh|200|$SHVIS bench --techniques $ENGINE_SH_ROWS --env $ENGINE_SH_ENV --out $OUT/engine-sh
bench relit90|90|$SHVIS bench --techniques $NMPRT_ROWS --relight-rotate 90 --point-reference --ref-spp 256 --frames 3 --warmup 1 --out $OUT/relit90
bench specular|165|$SHVIS bench --scene bumpy --techniques unc6,preconv,unc6ndf,preconvndf --specular mip,ndf,ndfn --light-dir 0,0.3,-1 --vis-res 256 --rays 256 --width 640 --height 360 --out $OUT/specular
STEPS
}

# The estimate of a step: its seconds in the last run here, else the default.
estimate() {
    last=$(grep -F "$1|" "$TIMES" 2>/dev/null | tail -n 1 | cut -d'|' -f2 || true)
    echo "${last:-$2}"
}

minutes() { echo "$(( $1 / 60 )) min $(( $1 % 60 )) s"; }

total=0
count=0
source_note="this machine's last run"
[ -f "$TIMES" ] || source_note="a 2-core lavapipe machine's times: no run here yet"
echo "plan: make bench-full runs:"
steps > "$CACHE/bench-full-steps.$$"
while IFS='|' read -r name default cmd; do
    s=$(estimate "$name" "$default")
    total=$(( total + s ))
    count=$(( count + 1 ))
    echo "plan:   $name — about $(minutes "$s")"
done < "$CACHE/bench-full-steps.$$"
echo "plan: about $(minutes "$total") in all ($source_note)"

started=$(date +%s)
left=$total
k=0
: > "$TIMES.new"
while IFS='|' read -r name default cmd; do
    k=$(( k + 1 ))
    echo "[$k/$count] $name — about $(minutes "$left") left in all"
    t0=$(date +%s)
    sh -c "$cmd" < /dev/null
    t=$(( $(date +%s) - t0 ))
    echo "$name|$t" >> "$TIMES.new"
    left=$(( left - $(estimate "$name" "$default") ))
    [ "$left" -ge 0 ] || left=0
done < "$CACHE/bench-full-steps.$$"
rm -f "$CACHE/bench-full-steps.$$"
mv "$TIMES.new" "$TIMES"
echo "make bench-full: $(( $(date +%s) - started )) s after the build (the plan said about $total s)"
