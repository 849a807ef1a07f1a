#!/usr/bin/env bash
# CTest: spacearm view's pages in a real browser (web/test/view_test.mjs: Debian's Chromium,
# headless, driven by playwright-core, offline). Makes the paper's plan and its p = 10 replay, a
# spatial arm's free motion, two arms on one satellite (a plan holding one tool, flown), a scene
# with a hostile name and a small study with time series,
# checks what the CLI says (thinning, errors), then runs the browser checks. Screenshots are left
# in $SPACEARM_VIEW_OUT if set. About 50 s (five models compiled). Skipped (77) without Chromium.
# Usage: view_browser.sh SPACEARM SOURCE_DIR NODE_MODULES
set -euo pipefail
cli=$(realpath "$1") source_dir=$(realpath "$2") modules=$(realpath "$3")
[[ -x ${SPACEARM_CHROMIUM:-/usr/bin/chromium} ]] || { echo "chromium missing: skipped"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cache=(--cache-dir "$work/cache")
fail() { echo "FAIL: $*"; exit 1; }
run() { "$@" > "$work/log" 2>&1 || { cat "$work/log"; fail "$*"; }; }

# The paper's plan (reference model) and its replay into the geared model at p = 10.
run "$cli" plan "$source_dir/models/paper_reference.yaml" --from 0.9,0.3,0.3 --to 0.8,0.5,0.6 \
  --duration 4 -o "$work/plan.csv" "${cache[@]}"
run "$cli" simulate "$source_dir/models/paper_geared.yaml" --plan "$work/plan.csv" --param p=10 \
  -o "$work/replay.csv" "${cache[@]}"
# The scene and p = 10 come from the replay's provenance (replay.csv.provenance.json).
run "$cli" view "$work/replay.csv" --compare "$work/plan.csv" -o "$work/paper.html" "${cache[@]}"
grep -q '"run made by","[^"]*spacearm simulate [^"]*paper_geared.yaml --plan [^"]*--param p=10' \
  "$work/paper.html" || fail "the page does not show the command that made the run"
grep -q '"parameter p","10"' "$work/paper.html" || fail "the run's p = 10 is not the page's"
# The same scene named by another path still takes the record's parameters.
(cd "$source_dir/models" && "$cli" view "$work/replay.csv" --scene ./paper_geared.yaml \
  -o "$work/relative.html" "${cache[@]}") > "$work/log" 2>&1 || { cat "$work/log"; fail "relative"; }
grep -q '"parameter p","10"' "$work/relative.html" || fail "a relative --scene lost the record's p"

# Thinning: at most --max-frames rows drawn, and the page says so.
run "$cli" view "$work/replay.csv" --scene "$source_dir/models/paper_geared.yaml" --max-frames 50 \
  -o "$work/thin.html" "${cache[@]}"
grep -Eq "401 rows, thinned for drawing to (4[0-9]|50) \(every [0-9]+th and the last\)" "$work/thin.html" ||
  fail "the thinned page does not say so"

# Bad input: the CLI's errors, naming the file or option; nothing written.
expect_error() {  # pattern, then the command
  local pattern=$1
  shift
  if "$@" > "$work/log" 2>&1; then fail "accepted: $*"; fi
  grep -q "$pattern" "$work/log" || { cat "$work/log"; fail "no message '$pattern' for: $*"; }
}
printf 't,x0\n0,1\n' > "$work/short.csv"
expect_error "has neither the scene's coordinates" "$cli" view "$work/short.csv" \
  --scene "$source_dir/models/paper_geared.yaml" -o "$work/bad.html" "${cache[@]}"
sed '3s/^[^,]*,/0.5x,/' "$work/replay.csv" > "$work/garbled.csv"
expect_error "line 3 column 't'" "$cli" view "$work/garbled.csv" \
  --scene "$source_dir/models/paper_geared.yaml" -o "$work/bad.html" "${cache[@]}"
mkfifo "$work/fifo"
expect_error "is not a regular file" timeout 20 "$cli" view "$work/fifo" \
  --scene "$source_dir/models/paper_geared.yaml" -o "$work/bad.html" "${cache[@]}"
cp "$work/replay.csv" "$work/copy.csv"  # a new file: its provenance no longer matches
cp "$work/replay.csv.provenance.json" "$work/copy.csv.provenance.json"
expect_error "give --scene" "$cli" view "$work/copy.csv" -o "$work/bad.html"
echo '{"command": 1}' > "$work/copy.csv.provenance.json"
expect_error "copy.csv.provenance.json': not spacearm's provenance" "$cli" view "$work/copy.csv" \
  -o "$work/bad.html"
# Issue 49: a record that is a link, or not JSON, is named, never quoted (it could be any file).
printf 'secret-text-1234\n' > "$work/secret"
rm "$work/copy.csv.provenance.json"
ln -s "$work/secret" "$work/copy.csv.provenance.json"
expect_error "copy.csv.provenance.json' is a symbolic link" "$cli" view "$work/copy.csv" \
  -o "$work/bad.html"
! grep -q secret-text "$work/log" || fail "the linked record's text was shown"
rm "$work/copy.csv.provenance.json"
printf 'secret-text-5678 is no JSON\n' > "$work/copy.csv.provenance.json"
expect_error "not spacearm's provenance (not JSON at byte" "$cli" view "$work/copy.csv" \
  -o "$work/bad.html"
! grep -q secret-text "$work/log" || fail "the record's text was shown"
expect_error "is the run file" "$cli" view "$work/replay.csv" \
  --scene "$source_dir/models/paper_geared.yaml" -o "$work/replay.csv" "${cache[@]}"
# Another p than the run's: the drawn end effector would not be the file's ee_x, ee_y.
expect_error "the scene puts the end effector .* m from the file's ee_ columns" "$cli" view \
  "$work/replay.csv" --param p=3 -o "$work/bad.html" "${cache[@]}"
# A record naming a FIFO, or a relative path, as the scene; -o naming a record.
mkfifo "$work/scene.fifo"
sed "s|\"scene\": \"[^\"]*\"|\"scene\": \"$work/scene.fifo\"|" "$work/replay.csv.provenance.json" \
  > "$work/fifo_record.json"
cp "$work/replay.csv" "$work/fifo_run.csv"
touch -r "$work/replay.csv" "$work/fifo_run.csv"
mv "$work/fifo_record.json" "$work/fifo_run.csv.provenance.json"
expect_error "names the scene '.*scene.fifo', not a regular file" timeout 20 "$cli" view \
  "$work/fifo_run.csv" -o "$work/bad.html"
expect_error "is the run's provenance file" "$cli" view "$work/replay.csv" \
  -o "$work/replay.csv.provenance.json" "${cache[@]}"
[[ ! -e $work/bad.html ]] || fail "a page was written for bad input"

# Issue 52: two arms on one satellite, the left one planned while the right one holds its pose,
# flown and drawn (every branch, both tools).
run "$cli" plan "$source_dir/models/dual_arm7.yaml" --from 0.6,0.5,2.67 --to 0.9,0.6,2.3 \
  --duration 4 --end-effector l_tool_flange --hold pose -o "$work/dual_plan.csv" "${cache[@]}"
run "$cli" simulate "$source_dir/models/dual_arm7.yaml" --plan "$work/dual_plan.csv" \
  --dt-out 0.1 -o "$work/dual.csv" "${cache[@]}"
run "$cli" view "$work/dual.csv" -o "$work/dual.html" "${cache[@]}"

# A URDF arm (identified inertias) drawn with its <visual> shapes, an STL mesh on Link_2 (a
# tetrahedron, binary STL, by package:// path) among them.
mkdir -p "$work/urdf/meshes"
cp "$source_dir/models/identified_arm3.yaml" "$work/urdf/"
sed 's|<link name="Link_2">|&<visual><geometry><mesh filename="package://arm/meshes/tetra.stl" scale="0.5 0.5 0.5"/></geometry></visual>|' \
  "$source_dir/models/identified_arm3.urdf" > "$work/urdf/identified_arm3.urdf"
/usr/bin/python3 - "$work/urdf/meshes/tetra.stl" <<'PY'
import struct, sys
v = [(0, 0, 0), (0.4, 0, 0), (0, 0.4, 0), (0, 0, 0.4)]
faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
with open(sys.argv[1], "wb") as f:
    f.write(b"tetra".ljust(80, b" ") + struct.pack("<I", len(faces)))
    for a, b, c in faces:
        f.write(struct.pack("<12fH", 0, 0, 0, *v[a], *v[b], *v[c], 0))
PY
run "$cli" simulate "$work/urdf/identified_arm3.yaml" --zero --t-end 1 --dt 0.01 \
  --qd0 0,0,0,0,0,0,0.2,-0.3,0.4 -o "$work/urdf.csv" "${cache[@]}"
run "$cli" view "$work/urdf.csv" --scene "$work/urdf/identified_arm3.yaml" \
  -o "$work/urdf.html" "${cache[@]}"
# --camera: the arm alone, or a point to look from; bad values refused by name.
run "$cli" view "$work/urdf.csv" --scene "$work/urdf/identified_arm3.yaml" --camera arm \
  -o "$work/urdf_arm.html" "${cache[@]}"
run "$cli" view "$work/urdf.csv" --scene "$work/urdf/identified_arm3.yaml" \
  --camera 6,-4,3,1.5,0,0.8 -o "$work/urdf_eye.html" "${cache[@]}"
expect_error "view: --camera: expected all, arm or x,y,z\[,tx,ty,tz\], got 'wide'" "$cli" view \
  "$work/urdf.csv" --scene "$work/urdf/identified_arm3.yaml" --camera wide -o "$work/bad.html" \
  "${cache[@]}"
expect_error "the point to look from is the point to look at" "$cli" view "$work/urdf.csv" \
  --scene "$work/urdf/identified_arm3.yaml" --camera 1,2,3,1,2,3 -o "$work/bad.html" "${cache[@]}"
expect_error "a point to look from is for a spatial run" "$cli" view "$work/replay.csv" \
  --camera 1,2,3 -o "$work/bad.html" "${cache[@]}"
# A mesh that leaves the URDF's folder through a link, or is no STL, is refused by name.
printf 'secret-text-9012\n' > "$work/secret.stl"
mv "$work/urdf/meshes/tetra.stl" "$work/tetra.stl"
ln -s "$work/secret.stl" "$work/urdf/meshes/tetra.stl"
expect_error "mesh '.*tetra.stl' is not a file inside the URDF's folder" "$cli" view \
  "$work/urdf.csv" --scene "$work/urdf/identified_arm3.yaml" -o "$work/bad.html" "${cache[@]}"
rm "$work/urdf/meshes/tetra.stl"
printf 'secret-text-9012\n' > "$work/urdf/meshes/tetra.stl"
expect_error "mesh '.*tetra.stl' is not an STL file" "$cli" view \
  "$work/urdf.csv" --scene "$work/urdf/identified_arm3.yaml" -o "$work/bad.html" "${cache[@]}"
! grep -q secret-text "$work/log" || fail "the refused mesh's text was shown"
# Found in review: an ASCII STL is read here and handed to the page as binary (three.js's ASCII
# parser takes quadratic time on a hostile file); coordinates not finite or beyond 1e6 m are
# refused; a scene named without a folder finds its meshes.
printf 'solid t\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex nan 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n' \
  > "$work/urdf/meshes/tetra.stl"
expect_error "mesh '.*tetra.stl' has a vertex coordinate that is not finite or beyond 1e6" "$cli" \
  view "$work/urdf.csv" --scene "$work/urdf/identified_arm3.yaml" -o "$work/bad.html" "${cache[@]}"
{ printf 'solid facet '; for _ in $(seq 20000); do printf 'solid '; done; } > "$work/urdf/meshes/tetra.stl"
expect_error "mesh '.*tetra.stl' is not an STL file (no facets of three vertices)" timeout 20 "$cli" \
  view "$work/urdf.csv" --scene "$work/urdf/identified_arm3.yaml" -o "$work/bad.html" "${cache[@]}"
/usr/bin/python3 - "$work/urdf/meshes/tetra.stl" <<'PY'
import sys
v = [(0, 0, 0), (0.4, 0, 0), (0, 0.4, 0), (0, 0, 0.4)]
facets = "".join("facet normal 0 0 0\nouter loop\n" + "".join("vertex %g %g %g\n" % v[i] for i in f)
                 + "endloop\nendfacet\n" for f in [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)])
open(sys.argv[1], "w").write("solid tetra\n" + facets + "endsolid tetra\n")
PY
(cd "$work/urdf" && "$cli" view ../urdf.csv --scene identified_arm3.yaml -o "$work/ascii.html" \
  "${cache[@]}") > "$work/log" 2>&1 || { cat "$work/log"; fail "an ASCII STL, the scene by its bare name"; }
# base64 of 84 + 4 x 50 bytes (380 characters), quoted, and grep's newline.
[[ $(grep -o '"stl":"[^"]*"' "$work/ascii.html" | wc -c) -eq $((4 * 95 + 9)) ]] ||
  fail "the ASCII tetrahedron is not in the page as a binary STL of 4 triangles"
mv "$work/tetra.stl" "$work/urdf/meshes/tetra.stl"
[[ ! -e $work/bad.html ]] || fail "a page was written for a refused mesh"
# A spatial arm turning its joints from rest, the base reacting.
run "$cli" simulate "$source_dir/tests/scenes/spatial_arm2.yaml" --zero --t-end 1 --dt 0.01 \
  --qd0 0,0,0,0,0,0.2,60,-30 -o "$work/spatial.csv" "${cache[@]}"
run "$cli" view "$work/spatial.csv" --scene "$source_dir/tests/scenes/spatial_arm2.yaml" \
  -o "$work/spatial.html" "${cache[@]}"

# A row whose base quaternion is zero is not a rotation.
awk -F, -v OFS=, 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == "qw0") c = i }
                 NR == 4 { $c = 0; $(c + 1) = 0; $(c + 2) = 0; $(c + 3) = 0 } { print }' \
  "$work/spatial.csv" > "$work/zero_quaternion.csv"
expect_error "zero_quaternion.csv' at t = 0.02.*quaternion's norm is 0" "$cli" view \
  "$work/zero_quaternion.csv" --scene "$source_dir/tests/scenes/spatial_arm2.yaml" \
  -o "$work/bad.html" "${cache[@]}"

# A scene that emits neither joint positions nor energy: the view compiles a variant with them.
{ cat "$source_dir/tests/scenes/fixed_n1.yaml"; echo "outputs: [forward_dynamics]"; } > "$work/bare.yaml"
run "$cli" simulate "$work/bare.yaml" --zero --t-end 0.5 --qd0 1 -o "$work/bare.csv" "${cache[@]}"
run "$cli" view "$work/bare.csv" -o "$work/bare.html" "${cache[@]}"
grep -q '"title":"energy"' "$work/bare.html" || fail "no energy plot for a scene without kinetic_energy"

# Markup in the scene's description and in the run's file name: it must show as text.
sed -e 's|^description: .*|description: "</script><script>window.pwned=1</script>"|' \
    "$source_dir/models/paper_geared.yaml" > "$work/hostile.yaml"
hostile_csv="$work/<img src=x onerror=window.pwned=2>.csv"
run "$cli" simulate "$work/hostile.yaml" --zero --t-end 0.2 --dt 0.01 --qd0 0,0,0,1,1,1 \
  -o "$hostile_csv" "${cache[@]}"
run "$cli" view "$hostile_csv" --scene "$work/hostile.yaml" -o "$work/hostile.html" "${cache[@]}"
if grep -q "<script>window.pwned\|<img src" "$work/hostile.html"; then
  fail "the hostile text is in the page as markup"
fi

# A study over p and Im with time series.
cat > "$work/study.yaml" <<YAML
scene: $source_dir/models/paper_geared.yaml
manoeuvre:
  plan: {from: [1.5, 0.0, 0.5235987755982988], to: [1.45, 0.02, 0.55], duration: 1}
integrator: {method: rk4, dt: 0.01}
grid:
  p: [1, 2, 4]
  Im: [1.0e-6, 1.0e-5, 1.0e-4]
time_series: {dt: 0.05}
YAML
run "$cli" sweep "$work/study.yaml" -o "$work/study" "${cache[@]}"
run "$cli" view "$work/study/results.csv" -o "$work/study.html"
# A bad time series is skipped with a note, not the whole page; -o may not name a series.
cp -r "$work/study" "$work/study2"
echo "garbage" > "$work/study2/series/run-00000004.csv"
run "$cli" view "$work/study2/results.csv" -o "$work/study2.html"
grep -q "1 time series skipped, the first: .*run-00000004.csv" "$work/study2.html" ||
  fail "the bad series is not named in the page"
expect_error "is a study's time series file" "$cli" view "$work/study/results.csv" \
  -o "$work/study/series/run-00000000.csv"

status=0
# Random draws (a Monte Carlo): the metric follows the third parameter alone; some runs failed.
mkdir -p "$work/random"
awk 'BEGIN { srand(7); print "run,status,g1,g2,mp,ee_x,ee_error,command_ratio,message"
             for (i = 0; i < 300; ++i) { g1 = rand(); g2 = rand(); mp = 50 * rand()
               if (i % 37 == 5) printf "%d,failed,%.9g,%.9g,%.9g,,,run,\"diverged\"\n", i, g1, g2, mp
               else printf "%d,ok,%.9g,%.9g,%.9g,1,%.9g,run,\n", i, g1, g2, mp, 1e-3 * mp + 1e-5 * rand() } }' \
  > "$work/random/results.csv"
run "$cli" view "$work/random/results.csv" -o "$work/random.html"

# A parameter over +-1e308, drawn (not a grid): 40 bins that do not overflow.
mkdir -p "$work/wide"
awk 'BEGIN { print "run,status,p,ee_x,ee_error,message"
             for (i = 0; i <= 60; ++i) printf "%d,ok,%.17g,1,%g,\n", i, (-1 + i / 30) * 1e308, i }' \
  > "$work/wide/results.csv"
run "$cli" view "$work/wide/results.csv" -o "$work/wide.html"
counts=$(grep -o '"counts":\[[^]]*\]' "$work/wide.html")
[[ $(tr -c '0-9\n' ' ' <<< "$counts" | tr ' ' '\n' | sort -n | tail -1) -le 3 ]] ||
  fail "the runs over +-1e308 are not spread over the bins: $counts"

node "$source_dir/web/test/view_test.mjs" "$modules" "$work" || status=$?
if [[ -n ${SPACEARM_VIEW_OUT:-} ]]; then
  mkdir -p "$SPACEARM_VIEW_OUT"
  cp "$work"/*.png "$work"/paper.html "$work"/spatial.html "$work"/study.html "$SPACEARM_VIEW_OUT"/
fi
exit $status
