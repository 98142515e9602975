#!/usr/bin/env bash
# The batch-scheduler examples of docs/splitting.md,
# tested for real. Opt-in, not part of `cargo test` (it installs packages and starts daemons):
#
#   bash scripts/scheduler-check.sh
#
# Slurm: installs slurm-wlm and munge where missing (Debian, as root), starts a private munged
# and a one-node Slurm cluster on localhost from a slurm.conf it writes (ports, state and logs
# under target/scheduler-check/), and there
#   1. submits docs/distributed/slurm.sbatch with docs/splitting.md's two sbatch lines, read from
#      docs/splitting.md and run as they are, as a job array of PARTS=4 parts plus the merge job
#      (SPP=16 RES=64x64 BACKEND=cpu), and checks that the merged EXR equals a one-process CPU
#      render of the same samples bit for bit (`brdfwave diff --max max_abs=0`);
#   2. submits them again with more samples per part (SPP=256), cancels one array task while
#      it renders (its part is then absent: parts are written atomically), requeues it, submits
#      the merge job again as docs/splitting.md says, and checks that the task rendered its part again,
#      that every part is there once, and that the merge is again exact.
# Kubernetes: validates docs/distributed/k8s-*.yaml against the Kubernetes API schema with
# kubernetes-validate (PyPI; installed into target/scheduler-check/venv where missing), strict
# (unknown fields are errors), and checks that the validator refuses a manifest with a
# misspelt field.
#
# Where it cannot run (not Linux, not root and Slurm missing, no apt-get, no python3 venv, a
# package that does not install) it says why and counts that check as skipped. The last line
# is "N passed, N failed[, N skipped]"; the exit status is 1 when a check failed, else 0.
# Everything it started (munged, slurmctld, slurmd) is stopped by its process id on exit.
set -uo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
work=$repo/target/scheduler-check
passed=0 failed=0 skipped=0
pass() { echo "PASS: $*"; passed=$((passed + 1)); }
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }
skip() { echo "SKIPPED: $*"; skipped=$((skipped + 1)); }
summary() { echo "$passed passed, $failed failed$([ "$skipped" -gt 0 ] && echo ", $skipped skipped")"; }
started=()
cleanup() {
    # Stop what this script started, newest first, by process id.
    local i
    for ((i = ${#started[@]} - 1; i >= 0; i--)); do
        kill "${started[i]}" 2>/dev/null && wait "${started[i]}" 2>/dev/null
    done
}
trap cleanup EXIT
log() { echo "[$(date +%H:%M:%S)] $*"; }

rm -rf "$work"
mkdir -p "$work"
bin=${BRDFWAVE:-$repo/target/release/brdfwave}
if [ ! -x "$bin" ]; then
    log "building brdfwave (cargo build --release)"
    cargo build --release --quiet || { fail "cargo build --release"; summary; exit 1; }
fi
bin=$(realpath "$bin")

# ---------------------------------------------------------------------------------- Kubernetes
k8s_check() {
    local venv=$work/venv kv
    kv=$(command -v kubernetes-validate || true)
    if [ -z "$kv" ]; then
        python3 -m venv "$venv" >/dev/null 2>&1 || { skip "Kubernetes: python3 -m venv failed (python3-venv missing?)"; return; }
        log "installing kubernetes-validate (PyPI) into $venv"
        "$venv/bin/pip" install --quiet --disable-pip-version-check kubernetes-validate >"$work/pip.log" 2>&1 ||
            { skip "Kubernetes: pip install kubernetes-validate failed: $(tail -1 "$work/pip.log")"; return; }
        kv=$venv/bin/kubernetes-validate
    fi
    log "kubernetes-validate $("$kv" --version 2>&1 | tail -1), strict, on docs/distributed/k8s-*.yaml"
    if "$kv" --strict docs/distributed/k8s-*.yaml; then
        pass "Kubernetes: docs/distributed/k8s-*.yaml are valid batch/v1 Jobs (strict schema)"
    else
        fail "Kubernetes: the manifests do not validate"
    fi
    # The validator is not blind: a misspelt field is refused.
    sed 's/backoffLimitPerIndex:/backofLimitPerIndex:/' docs/distributed/k8s-parts.yaml >"$work/misspelt.yaml"
    if "$kv" --strict "$work/misspelt.yaml" >"$work/misspelt.log" 2>&1; then
        fail "Kubernetes: the validator accepted a misspelt field (backofLimitPerIndex)"
    else
        log "a misspelt field is refused: $(grep -m1 -i -E 'error|backof' "$work/misspelt.log")"
    fi
}
k8s_check

# --------------------------------------------------------------------------------------- Slurm
# Installs what is missing; returns 1 (after a skip) where it cannot.
slurm_install() {
    if [ "$(uname -s)" != Linux ]; then skip "Slurm: not Linux"; return 1; fi
    local missing=0 c
    for c in slurmctld slurmd sbatch squeue scontrol scancel munged mungekey; do
        command -v "$c" >/dev/null || missing=1
    done
    id munge >/dev/null 2>&1 || missing=1
    [ "$missing" = 0 ] && return 0
    if [ "$(id -u)" != 0 ]; then skip "Slurm: slurm-wlm or munge missing, and installing them needs root"; return 1; fi
    if ! command -v apt-get >/dev/null; then skip "Slurm: slurm-wlm or munge missing, and no apt-get"; return 1; fi
    log "installing slurm-wlm and munge (apt-get)"
    if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge; } >"$work/apt.log" 2>&1; then
        skip "Slurm: apt-get install slurm-wlm munge failed: $(tail -1 "$work/apt.log")"
        return 1
    fi
}

# A free TCP port on localhost.
free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }

# Starts munged and a one-node cluster; sets SLURM_CONF. Returns 1 (after a fail) on error.
slurm_start() {
    local m=$work/munge host node cpus
    if [ "$(id -u)" != 0 ]; then skip "Slurm: the daemons run as root here, and this is not root"; return 1; fi
    mkdir -p "$m" && chown munge: "$m" && chmod 755 "$m"
    runuser -u munge -- mungekey --create --keyfile="$m/munge.key" || { fail "Slurm: mungekey"; return 1; }
    runuser -u munge -- munged --foreground --socket="$m/munge.socket" --key-file="$m/munge.key" \
        --pid-file="$m/munged.pid" --log-file="$m/munged.log" --seed-file="$m/munged.seed" \
        >"$work/munged.out" 2>&1 &
    started+=($!)
    host=$(hostname -s)
    node=$(slurmd -C | head -1)
    cpus=$(sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' <<<"$node")
    mkdir -p "$work/state" "$work/spool"
    cat >"$work/slurm.conf" <<EOF
# Written by scripts/scheduler-check.sh: a one-node cluster on localhost.
ClusterName=brdfwave-check
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$m/munge.socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
MinJobAge=3600
KillWait=5
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=check Nodes=$host Default=YES State=UP
EOF
    export SLURM_CONF=$work/slurm.conf
    slurmctld -D -c -f "$SLURM_CONF" >>"$work/slurmctld.out" 2>&1 &
    started+=($!)
    slurmd -D -f "$SLURM_CONF" -N "$host" >>"$work/slurmd.out" 2>&1 &
    started+=($!)
    local t
    for t in $(seq 60); do
        [ "$(timeout 5 sinfo -h -N -o %T 2>/dev/null)" = idle ] && break
        sleep 1
    done
    if [ "$(timeout 5 sinfo -h -N -o %T 2>/dev/null)" != idle ]; then
        fail "Slurm: the node did not come up in 60 s: $(timeout 5 sinfo -N 2>&1 | tail -1); logs in $work"
        return 1
    fi
    log "one-node cluster up: $(sinfo -h -o '%P %D nodes, %c CPUs, time limit %l')"
}

# docs/splitting.md's Slurm lines, as they are: submit (2 lines: the parts, the merge) or requeue (the
# requeue of a task and the replacement of the merge job).
readme_lines() {
    case $1 in
    submit) grep -E '^(jid=\$\(sbatch |mjid=\$\(sbatch --parsable --dependency=afterok)' docs/splitting.md ;;
    requeue) grep -E '^(scontrol requeue |scancel \$mjid )' docs/splitting.md ;;
    esac
}

# A job's state (scontrol keeps finished jobs for MinJobAge).
job_state() { scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -1; }

# Waits until job $1 (array tasks included) has finished, at most $2 seconds; then prints its
# state. Prints why it is pending when it times out.
wait_job() {
    local id=$1 limit=$2 t
    for ((t = 0; t < limit; t++)); do
        [ -z "$(squeue -h -j "$id" 2>/dev/null)" ] && break
        sleep 1
    done
    if [ -n "$(squeue -h -j "$id" 2>/dev/null)" ]; then
        squeue -j "$id" -o '%i %T %r' | sed 's/^/    /'
        echo TIMEOUT
        return
    fi
    job_state "$id"
}

# Runs docs/splitting.md's lines of $1 (readme_lines) from the repository root; checks that there are $2.
run_readme() {
    local lines
    lines=$(readme_lines "$1")
    [ "$(grep -c . <<<"$lines")" = "$2" ] || { fail "Slurm: docs/splitting.md's $1 lines not found"; return 1; }
    echo "$lines" | sed 's/^/    $ /'
    # In this shell (not a subshell): the lines set jid and mjid.
    eval "$lines" >"$work/$1.out" 2>&1 || { fail "Slurm: $(cat "$work/$1.out")"; return 1; }
    sed 's/^/    /' "$work/$1.out"
}

# Submits with the settings in the environment; docs/splitting.md's lines set jid and mjid.
submit() {
    run_readme submit 2 || return 1
    [ -n "${jid:-}" ] && [ -n "${mjid:-}" ] || { fail "Slurm: docs/splitting.md's lines gave no job ids"; return 1; }
    log "array job $jid (tasks 0-$((PARTS - 1))), merge job $mjid"
}

# The one-process CPU render of the same samples, and the exact comparison.
exact() {
    local single=$work/$1-single.exr
    "$bin" render scenes/cornell-box.toml --backend cpu --res "$RES" --spp "$SPP" --quiet --out "$single" ||
        { fail "Slurm: the one-process render"; return 1; }
    local verdict
    verdict=$("$bin" diff "$OUT" "$single" --json --max max_abs=0)
    echo "    brdfwave diff merged single: $verdict" | cut -c1-220
    grep -q '"pass":true' <<<"$verdict"
}

slurm_check() {
    slurm_install || return
    slurm_start || return
    export BRDFWAVE=$bin SCENE=scenes/cornell-box.toml
    # 1. docs/splitting.md's commands, 4 parts and the merge.
    export SPP=16 PARTS=4 RES=64x64 BACKEND=cpu OUT=$work/out/exact.exr
    log "1. SPP=$SPP PARTS=$PARTS RES=$RES BACKEND=$BACKEND OUT=$OUT"
    submit || return
    local state
    state=$(wait_job "$jid" 300)
    log "array job $jid: $state"
    state=$(wait_job "$mjid" 120)
    log "merge job $mjid: $state"
    log "task 0 rendered on: $(grep -h -m1 '^backend' "$repo/slurm-$jid-0.log" 2>/dev/null | tr -s ' ')"
    if [ "$state" = COMPLETED ] && exact 1; then
        pass "Slurm: docs/splitting.md's commands, 4 parts and the merge on a one-node cluster: the image equals the one-process CPU render bit for bit"
    else
        fail "Slurm: docs/splitting.md's commands: merge job $state; logs: $(ls "$repo"/slurm-"$jid"-*.log "$repo"/slurm-"$mjid"-*.log 2>/dev/null | tr '\n' ' ')"
    fi
    mv "$repo"/slurm-"$jid"-*.log "$repo"/slurm-"$mjid"-*.log "$work/" 2>/dev/null
    # 2. A task cancelled while it renders, then requeued.
    export SPP=256 OUT=$work/out/requeue.exr
    local dir=$work/out/requeue.parts victim=1
    log "2. SPP=$SPP PARTS=$PARTS RES=$RES BACKEND=$BACKEND OUT=$OUT: task $victim cancelled while it renders, then requeued"
    submit || return
    local t rendering=""
    for t in $(seq 300); do
        if [ "$(job_state "${jid}_$victim")" = RUNNING ] &&
            pgrep -f -- "--out $dir/part-$victim-of-$PARTS.bwfilm" >/dev/null; then
            rendering=yes
            break
        fi
        sleep 0.2
    done
    [ -n "$rendering" ] || { fail "Slurm: task ${jid}_$victim never rendered: $(squeue -j "$jid" 2>&1)"; return; }
    sleep 1
    scancel "${jid}_$victim"
    for t in $(seq 60); do
        [ "$(job_state "${jid}_$victim")" = CANCELLED ] && break
        sleep 0.5
    done
    state=$(job_state "${jid}_$victim")
    local leftovers
    leftovers=$(ls -A "$dir" 2>/dev/null | grep -v -E '^part-[0-9]+-of-[0-9]+\.bwfilm$' || true)
    log "task ${jid}_$victim: $state; its part file: $([ -e "$dir/part-$victim-of-$PARTS.bwfilm" ] && echo present || echo absent); other files in the parts folder: ${leftovers:-none}; merge job $mjid: $(squeue -h -j "$mjid" -o '%T (%r)')"
    [ "$state" = CANCELLED ] || { fail "Slurm: scancel ${jid}_$victim left it $state"; return; }
    # docs/splitting.md's lines: requeue the task, and replace the merge job (Slurm marked its afterok
    # never satisfied when the task was cancelled, and a requeue does not undo that).
    local task=$victim old_mjid=$mjid
    run_readme requeue 2 || return
    log "task ${jid}_$victim: $(squeue -h -j "${jid}_$victim" -o '%T (%r)'); merge job $old_mjid: $(job_state "$old_mjid"), replaced by $mjid: $(squeue -h -j "$mjid" -o '%T (%r)')"
    state=$(wait_job "$jid" 600)
    log "array job $jid: $state; task ${jid}_$victim: $(job_state "${jid}_$victim")"
    state=$(wait_job "$mjid" 120)
    log "merge job $mjid: $state"
    local parts
    parts=$(ls "$dir" | tr '\n' ' ')
    log "parts folder: $parts"
    local again
    again=$(grep -h "^wrote .*part-$victim-of-$PARTS.bwfilm" "$repo"/slurm-"$jid"-"$victim".log 2>/dev/null)
    log "the requeued task's log: ${again:-no part written}"
    if [ "$state" = COMPLETED ] && [ -n "$again" ] && [ "$(ls "$dir" | wc -l)" = "$PARTS" ] && exact 2; then
        pass "Slurm: a task cancelled mid-render and requeued renders its part again; every part is there once and the merge is exact"
    else
        fail "Slurm: after the requeue: merge job $state, parts: $parts"
    fi
    mv "$repo"/slurm-"$jid"-*.log "$repo"/slurm-"$mjid"-*.log "$work/" 2>/dev/null
}
slurm_check

summary
[ "$failed" = 0 ]
