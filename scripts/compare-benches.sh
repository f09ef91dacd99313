#!/usr/bin/env bash
# Are two builds as fast? For refactors that must not change speed.
#
#   scripts/compare-benches.sh OLD_REV [ROUNDS] [FILTER]
#
# Builds every criterion bench of OLD_REV (in the worktree compare-builds.sh uses, under
# target/compare/) and of the working tree, then runs each benchmark id both builds have,
# old and new alternating ROUNDS times (default 2), on one thread (RAYON_NUM_THREADS=1), and
# prints each id's median time per build (the median of its rounds) and the ratio new / old.
# A bench target may live in another package in one build (the lookup is by target name).
# FILTER (a regex on benchmark ids) narrows the run.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
old=${1:?usage: compare-benches.sh OLD_REV [ROUNDS] [FILTER]}
rounds=${2:-2}
filter=${3:-.}
work=$root/target/compare
. scripts/test-data.sh
mkdir -p "$work"

# benches SRC TARGET_DIR: "name path" of each bench executable of the workspace at SRC.
benches() {
  (cd "$1" && CARGO_TARGET_DIR=$2 cargo bench --workspace --no-run --message-format=json 2>/dev/null) |
    python3 -c '
import json, sys
for line in sys.stdin:
    try:
        m = json.loads(line)
    except ValueError:
        continue
    if m.get("reason") == "compiler-artifact" and "bench" in m["target"]["kind"] and m.get("executable"):
        print(m["target"]["name"], m["executable"])
'
}

src=$work/old-src
git worktree remove --force "$src" 2>/dev/null || rm -rf "$src"
git worktree add --detach --force "$src" "$old" >/dev/null
echo "== building the benches of $old and of the working tree"
benches "$src" "$work/old-target" > "$work/benches-old.txt"
benches "$root" "$root/target" > "$work/benches-new.txt"

python3 - "$work" "$rounds" "$filter" <<'PY'
import os, re, statistics, subprocess, sys
work, rounds, pattern = sys.argv[1], int(sys.argv[2]), re.compile(sys.argv[3])

def table(path):
    return dict(line.split(maxsplit=1) for line in open(path).read().split("\n") if line.strip())

old, new = table(f"{work}/benches-old.txt"), table(f"{work}/benches-new.txt")
env = dict(os.environ, RAYON_NUM_THREADS="1")
unit = {"ps": 1e-12, "ns": 1e-9, "µs": 1e-6, "us": 1e-6, "ms": 1e-3, "s": 1.0}

def ids(exe):
    out = subprocess.run([exe, "--bench", "--list"], env=env, capture_output=True, text=True).stdout
    return [l.rsplit(": ", 1)[0] for l in out.splitlines() if l.endswith(": benchmark")]

def median_time(exe, bench_id):
    # The id as an exact filter; criterion prints `time:   [low median high]`.
    out = subprocess.run([exe, "--bench", "--noplot", f"^{re.escape(bench_id)}$"], env=env,
                         capture_output=True, text=True).stdout
    m = re.search(r"time:\s+\[\S+ \S+ (\S+) (\S+)", out)
    return float(m.group(1)) * unit[m.group(2)] if m else None

rows = []
for target in sorted(set(old) & set(new)):
    for bench_id in ids(new[target]):
        if bench_id not in ids(old[target]) or not pattern.search(bench_id):
            continue
        times = {"old": [], "new": []}
        for _ in range(rounds):
            for side, exe in (("old", old[target]), ("new", new[target])):
                t = median_time(exe, bench_id)
                if t is not None:
                    times[side].append(t)
        if times["old"] and times["new"]:
            a, b = statistics.median(times["old"]), statistics.median(times["new"])
            rows.append((bench_id, a, b))
            print(f"{bench_id}: old {a * 1e3:.4g} ms, new {b * 1e3:.4g} ms, new/old {b / a:.3f}", flush=True)
print()
print("| bench | old | new | new / old |")
print("|---|---:|---:|---:|")
for bench_id, a, b in rows:
    print(f"| {bench_id} | {a * 1e3:.4g} ms | {b * 1e3:.4g} ms | {b / a:.3f} |")
PY
