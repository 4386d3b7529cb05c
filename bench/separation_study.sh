#!/bin/sh
# Separation study: data made by the simulator (ray-traced, independent of the fit), traced by
# sph_calibrate, scored against the truth. Not a test: a study anyone can rerun.
#
#   bench/separation_study.sh [BUILD_DIR] [RUNS] [NOISE_UM]      (defaults: build 5 0.05)
#
# Prints one row per case: the runs, how many found exactly the simulated effects, how many
# added an effect that was not simulated, the median form rms recovered / simulated (cases with
# the sphere turned on its mount), the median cv rms / sigma, and how often each effect was added.
set -eu
build=${1:-build}
runs=${2:-5}
noise=${3:-0.05}
sim="$build/apps/sph_simulate"
cal="$build/apps/sph_calibrate"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT INT TERM

form34="--form-um 3,1,0.06 --form-um 3,-2,0.05 --form-um 4,0,-0.07 --form-um 4,3,0.05 --form-um 3,3,0.04"
form28="--form-um 2,0,0.062 --form-um 2,2,-0.049 --form-um 3,1,0.049 --form-um 3,-3,0.037 --form-um 4,0,-0.043 \
--form-um 4,2,0.031 --form-um 5,-2,0.037 --form-um 5,4,-0.025 --form-um 6,1,0.031 --form-um 6,-5,0.025 \
--form-um 7,3,-0.025 --form-um 8,0,0.025 --form-um 8,-6,0.019"
turned="--center-mm 2,0,0 --center-mm 0,2,0 --center-mm 2,0,0 --mount-rotation-deg 1:0,0,90 \
--mount-rotation-deg 2:90,0,0 --scan-order 1:serpentine --scan-order 2:columns"

heights="--center-mm 2,0,0 --center-mm 0,2,3"
eccentricities="--center-mm 2,0,0 --center-mm 0,1,0"
two_spheres="--center-mm 2,0,0 --center-mm 2,0,0 --other-sphere-radius-mm 1:10"
# after $turned: a second sphere (R 10 mm) as setups 3 and 4, turned by 90 deg about z between them
second_turned="--center-mm 2,0,0 --center-mm 2,0,0 --other-sphere-radius-mm 3:10 --other-sphere-radius-mm 4:10 \
--mount-rotation-deg 4:0,0,90"
pivot="--phi-wobble-pivot-mm 80"

# name | expected effects (comma-separated ids, or -) | sph_simulate arguments | strip t_s (yes/no)
#      | sph_calibrate arguments
cases="drift+phi_enc|probe_drift,phi_encoder|--effect-um probe_drift.t1=0.6 --effect-arcsec phi_encoder.c1=10|no|
drift+nonlin_no_t|probe_drift,probe_nonlinearity|--effect-um probe_drift.t1=0.4 --effect-um probe_nonlinearity.u3=0.15|yes|
drift+form34|probe_drift|--effect-um probe_drift.t1=0.5 $form34|no|
theta_enc_5pt|theta_encoder|--effect-arcsec theta_encoder.c5=6|no|
clean|-||no|
form28_one|-|$form28|no|
form28+drift|probe_drift|$form28 --effect-um probe_drift.t1=0.4|no|
form28+drift_shuffled|probe_drift|$form28 --effect-um probe_drift.t1=0.4 --scan-order shuffled|no|
turned+form28+theta_enc|theta_encoder|$turned $form28 --effect-arcsec theta_encoder.c3=5|no|
turned+form34+drift|probe_drift|$turned $form34 --effect-um probe_drift.t1=0.4|no|
turned+form28+drift+theta_enc|probe_drift,theta_encoder|$turned $form28 --effect-um probe_drift.t1=0.4 --effect-arcsec theta_encoder.c3=5|no|
phi_radial_0.3|phi_radial_motion|--effect-um phi_radial_motion.x_c2=0.3|no|
phi_axial_2|phi_axial_motion|--effect-um phi_axial_motion.c2=2|no|
theta_tilt_10|theta_tilt_motion|--effect-arcsec theta_tilt_motion.x_c2=10|no|
heights+theta_tilt_10|theta_tilt_motion|$heights --effect-arcsec theta_tilt_motion.x_c2=10|no|
wobble_L80_2|phi_wobble|$pivot --effect-arcsec phi_wobble.x_c2=2|no|$pivot
eccentric_6+wobble_L80_2|phi_wobble|--center-mm 6,0,0 $pivot --effect-arcsec phi_wobble.x_c2=2|no|$pivot
incidence_30|probe_incidence|--effect-um probe_incidence.i1=30|no|
eccentricities+incidence_30|probe_incidence|$eccentricities --effect-um probe_incidence.i1=30|no|
gain_10|probe_gain|--effect-um probe_gain.u1=10|no|
two_spheres+gain_10|probe_gain|$two_spheres --effect-um probe_gain.u1=10|no|
two_spheres+incidence_30|probe_incidence|$two_spheres --effect-um probe_incidence.i1=30|no|
turned+form28+gain_10|probe_gain|$turned $form28 --effect-um probe_gain.u1=10|no|
turned+second_turned+form28+gain_10|probe_gain|$turned $second_turned $form28 --effect-um probe_gain.u1=10|no|
turned+second_turned+form28+incidence_30|probe_incidence|$turned $second_turned $form28 --effect-um probe_incidence.i1=30|no|"

printf '%-30s %5s %7s %7s %12s %10s  %s\n' case runs right wrong form_ratio cv/sigma 'effects added (count)'
echo "$cases" | while IFS='|' read -r name expected args strip cal_args; do
  i=1
  : >"$work/rows"
  while [ "$i" -le "$runs" ]; do
    # shellcheck disable=SC2086
    "$sim" -o "$work/p.txt" --truth "$work/t.json" --noise-r-um "$noise" --seed $((100 + i)) $args >/dev/null
    if [ "$strip" = yes ]; then
      awk '/^# columns:/{print "# columns: theta_deg phi_deg r_mm"; next} /^#/{print; next} {print $1, $2, $3}' \
        "$work/p.txt" >"$work/q.txt"
      mv "$work/q.txt" "$work/p.txt"
    fi
    # shellcheck disable=SC2086
    "$cal" "$work/p.txt" --json "$work/r.json" $cal_args >/dev/null 2>&1 || true
    /usr/bin/env python3 - "$work/r.json" "$work/t.json" "$expected" "$noise" >>"$work/rows" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
t = json.load(open(sys.argv[2]))
expected = set() if sys.argv[3] == "-" else set(sys.argv[3].split(","))
added = set(r.get("effects_added", []))
form = r.get("sphere_form", {})
truth_rms = t.get("form", {}).get("harmonics", {}).get("rms_um", 0.0)
ratio = form.get("rms_um", 0.0) / truth_rms if form.get("degree_max", 0) > 0 and truth_rms > 0 else float("nan")
print(int(added == expected), int(bool(added - expected)), ratio, r["after"]["cv_rms_um"] / float(sys.argv[4]),
      ",".join(sorted(added)) or "-")
EOF
    i=$((i + 1))
  done
  /usr/bin/env python3 - "$name" "$work/rows" <<'EOF'
import math, sys
lines = [l.split() for l in open(sys.argv[2]) if l.strip()]
rows = [list(map(float, l[:4])) for l in lines]
counts = {}
for l in lines:
    for e in l[4].split(","):
        if e != "-":
            counts[e] = counts.get(e, 0) + 1
def median(v):
    v = sorted(x for x in v if not math.isnan(x))
    return float("nan") if not v else (v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2]))
print("%-30s %5d %7d %7d %12.3f %10.3f  %s" % (sys.argv[1], len(rows), sum(r[0] for r in rows), sum(r[1] for r in rows),
                                             median([r[2] for r in rows]), median([r[3] for r in rows]),
                                             "  ".join("%s %d" % (e, k) for e, k in sorted(counts.items()))))
EOF
done
