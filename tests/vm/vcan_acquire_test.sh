#!/bin/bash
# sph_acquired and sph_cansim against a real Linux CAN stack: runs inside the VM of
# tests/vm/run-in-vcan-vm.sh (vcan0 up, can-utils on PATH), with the two programs in /work.
# The bytes of the NMT and SDO frames are checked as candump shows them (CiA 301: NMT 000#cs nn,
# SDO requests 600h + node, answers 580h + node, boot-up 700h + node with state 00), also where the
# daemon configures a node's heartbeat (1017h) and SYNC counter (1019h), restarts a node that left
# operational, reads a REAL32 probe, and leaves the bus as found after a refused start.
# Prints one line per check and "N passed, N failed"; exits 1 if any check failed.
cd /work || exit 1
pass=0
fail=0
check() {  # check "what" command...
  local what=$1; shift
  if "$@"; then echo "[  OK  ] $what"; pass=$((pass + 1)); else echo "[ FAIL ] $what"; fail=$((fail + 1)); fi
}
rows() { grep -vc '^#' "$1"; }
IP=/usr/sbin/ip
SIM=(./sph_cansim --iface vcan0 --theta-steps 6 --phi-steps 2 --stop-s 0.5 --move-s 0.2)

echo "== 1. simulator traffic answers the daemon's SYNC; candump sees that SYNC"
candump -L -n 20 vcan0,080:7FF >sync.log &
cd_pid=$!
"${SIM[@]}" --sync-source external --sync-period-ms 10 2>sim1.err &
sim_pid=$!
sleep 0.5
./sph_acquired --iface vcan0 -o stream.txt --sync-period-ms 10 --duration-s 5 --heartbeat-timeout-s 2.5 2>acq1.err
rc=$?
kill $sim_pid 2>/dev/null; wait $sim_pid; wait $cd_pid
n=$(rows stream.txt)
echo "   rows $n; daemon: $(grep -m1 'summary: frames' acq1.err)"
grep -E 'incomplete|missing' acq1.err | head -5 | sed 's/^/   /'
cycles=$(sed -n 's/.*summary: frames [0-9]*, SYNC [0-9]*, cycles \([0-9]*\),.*/\1/p' acq1.err | tail -1)
incomplete=$(sed -n 's/.*lost: incomplete cycles \([0-9]*\),.*/\1/p' acq1.err | tail -1)
missed=$(sed -n 's/.*, missed SYNC \([0-9]*\),.*/\1/p' acq1.err | tail -1)
recovered=$(sed -n 's/.*recovered cycles of missed SYNC \([0-9]*\);.*/\1/p' acq1.err | tail -1)
cut=$(sed -n 's/.*last cycle cut by the end \([0-9]*\).*/\1/p' acq1.err | tail -1)
# Under emulation the simulator sometimes answers a SYNC late: such a cycle must be reported, not lost.
# The cycles count those of SYNCs that never came: recovered ones are rows, the others lost.
check "daemon stopped cleanly, exit $rc (0, or 1 when cycles were incomplete)" test "$rc" -le 1
check "every SYNC cycle is a row or a reported loss: $n + $incomplete + $cut + $missed - $recovered = $cycles" \
  test $((n + incomplete + cut + missed - recovered)) -eq "$cycles"
check "rows from the simulator: $n of $cycles cycles" test "$n" -ge 300
check "candump saw the daemon's SYNC frames" test "$(grep -c ' 080#' sync.log)" -eq 20

echo "== 2. frames from cansend and cangen reach the daemon (external SYNC)"
./sph_acquired --iface vcan0 -o manual.txt --sync-mode follow --sync-period-ms 0 --duration-s 3 --no-nmt --no-sdo \
  2>acq2.err &
acq=$!
sleep 1
cansend vcan0 080#
cansend vcan0 181#01000000
cansend vcan0 182#00800000
cansend vcan0 183#40420F00
cansend vcan0 20000040#0000000000000000
cansend vcan0 083#3081110000000000
cansend vcan0 080#
cangen vcan0 -I 183 -L 2 -n 3 -g 10
wait $acq
cat acq2.err | sed 's/^/   /' | grep -v 'summary' | head -20
check "the cansend cycle is a row (theta 1 count, phi 2^15 counts, r 1 mm)" \
  grep -q '^0.0000214577 0.7031250000 1.0000000000 ' manual.txt
check "bus-off error frame logged" grep -q 'error frame: bus-off' acq2.err
check "EMCY logged with its code" grep -q 'EMCY 0x8130' acq2.err
check "short PDO from cangen counted as malformed" grep -q 'malformed probe PDO' acq2.err

echo "== 3. ip link set vcan0 down/up while acquiring"
"${SIM[@]}" --sync-source external --sync-period-ms 10 2>sim3.err &
sim_pid=$!
sleep 1  # the simulated devices must be listening before the daemon asks them over SDO
./sph_acquired --iface vcan0 -o updown.txt --sync-period-ms 10 --duration-s 6 --reopen-interval-s 0.2 2>acq3.err &
acq=$!
sleep 2
$IP link set vcan0 down
sleep 1
$IP link set vcan0 up
wait $acq
rc=$?
kill $sim_pid 2>/dev/null; wait $sim_pid
grep -E 'error|Network is down|up again|summary: frames|lost:' acq3.err | sed 's/^/   /'
after=$(awk '/up again, acquisition resumed/ {on = 1; next} on && !/^#/ {n++} END {print n + 0}' updown.txt 2>/dev/null)
check "daemon survived and stopped cleanly (exit $rc: 0 or 1)" test "$rc" -le 1
check "interface loss reported" grep -q 'Network is down: waiting for the interface' acq3.err
check "socket reopened when the interface came back" grep -q 'up again after' acq3.err
check "rows after the interface came back: $after (about 200)" test "$after" -ge 150

echo "== 4. throughput: canplayer sends a simulated 1 kHz log as fast as it can"
./sph_cansim -o khz.log --log-iface vcan0 --theta-steps 8 --phi-steps 2 --stop-s 0.5 --move-s 0.2 --sync-period-ms 1 2>/dev/null
sent=$(grep -c . khz.log)
./sph_acquired --iface vcan0 -o khz.txt --sync-mode follow --sync-period-ms 0 --rcvbuf-bytes 4194304 --duration-s 25 \
  --no-nmt --no-sdo 2>acq4.err &
acq=$!
sleep 1
t0=$(date +%s.%N)
canplayer -t -I khz.log
t1=$(date +%s.%N)
sleep 1
kill -TERM $acq; wait $acq
frames=$(sed -n 's/.*summary: frames \([0-9]*\),.*/\1/p' acq4.err | tail -1)
drops=$(sed -n 's/.*kernel drops (rx overflow) \([0-9]*\).*/\1/p' acq4.err | tail -1)
echo "   canplayer sent $sent frames in $(awk -v a=$t0 -v b=$t1 'BEGIN {printf "%.2f", b - a}') s ($(awk -v n=$sent -v a=$t0 -v b=$t1 'BEGIN {printf "%.0f", n / (b - a)}') frames/s); daemon received $frames, kernel dropped $drops"
grep -E 'summary: frames|lost:' acq4.err | sed 's/^/   /'
check "every frame received or counted as a kernel drop: $frames + $drops = $sent" test $((frames + drops)) -eq "$sent"

# start_follow OUT ERR [OPTIONS...]: sph_acquired on vcan0 with external SYNC, in the background ($acq);
# returns once its socket is bound (it logged "acquiring"), so no frame sent afterwards can miss it.
start_follow() {
  local out=$1 err=$2; shift 2
  ./sph_acquired --iface vcan0 -o "$out" --sync-mode follow --sync-period-ms 0 --duration-s 60 --no-nmt --no-sdo \
    "$@" 2>"$err" &
  acq=$!
  for _ in $(seq 100); do grep -q ': acquiring' "$err" && return 0; sleep 0.05; done
  return 1
}
counts() {  # counts ERR: "frames drops" from the daemon's last summary
  echo "$(sed -n 's/.*summary: frames \([0-9]*\),.*/\1/p' "$1" | tail -1) $(sed -n 's/.*kernel drops (rx overflow) \([0-9]*\).*/\1/p' "$1" | tail -1)"
}
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.3f", b - a}'; }

echo "== 4b. receive-queue overflow: the daemon stopped (SIGSTOP) while cangen floods its smallest queue"
start_follow ovf.txt acq4b.err --rcvbuf-bytes 1   # SO_RCVBUF 1: the kernel's minimum, a few frames
sent=2000
kill -STOP $acq
cangen vcan0 -I 181 -L 8 -g 0 -n $sent
kill -CONT $acq
sleep 0.5
kill -TERM $acq; wait $acq
rc=$?
read -r frames drops < <(counts acq4b.err)
grep -E 'kernel dropped|summary: frames|lost:' acq4b.err | sed 's/^/   /'
check "exit 1 (samples lost), got $rc" test "$rc" -eq 1
check "the kernel dropped frames and the summary says so: $drops" test "${drops:-0}" -gt 0
check "every frame received or counted as a kernel drop: $frames + $drops = $sent" test $((frames + drops)) -eq "$sent"
noted=$(awk '/^#.*the kernel dropped [0-9]+ received frames/ {for (i = 1; i < NF; i++) if ($i == "dropped") n += $(i + 1)} END {print n + 0}' ovf.txt)
check "the drops are comments in the points file: $noted" test "$noted" -eq "${drops:-0}"
check "the drops are in the loss total" grep -q "samples were lost: $drops " acq4b.err

echo "== 4c. highest sustained rate: canplayer at 1000..6000 frames/s, then cangen -g 0 (default SO_RCVBUF)"
best=0
for rate in 1000 2000 4000 6000 flood; do
  start_follow rate.txt rate.err
  if [ "$rate" = flood ]; then
    sent=10000
    t0=$EPOCHREALTIME
    cangen vcan0 -I 181 -L 8 -g 0 -n $sent
    t1=$EPOCHREALTIME
  else
    sent=$((rate * 3 / 2))  # 1.5 s of PDOs at the rate
    awk -v n=$sent -v r=$rate 'BEGIN {for (i = 0; i < n; i++) printf "(%.6f) vcan0 181#%08X00000000\n", 100 + i / r, i}' >rate.log
    t0=$EPOCHREALTIME
    canplayer -I rate.log
    t1=$EPOCHREALTIME
  fi
  sleep 0.5
  kill -TERM $acq; wait $acq
  read -r frames drops < <(counts rate.err)
  fps=$(awk -v n=$sent -v s="$(elapsed "$t0" "$t1")" 'BEGIN {printf "%.0f", n / s}')
  echo "   $rate: sent $sent in $(elapsed "$t0" "$t1") s ($fps frames/s), received $frames, kernel drops $drops"
  check "at $rate every frame received or counted as a kernel drop: $frames + $drops = $sent" \
    test $((frames + drops)) -eq "$sent"
  [ "${drops:-1}" -eq 0 ] && [ "$fps" -gt "$best" ] && best=$fps
done
echo "vm max sustained: $best frames/s, 0 drops (daemon with the default receive buffer, one vCPU under TCG)"

echo "== 5. SIGTERM flushes and closes"
./sph_acquired --iface vcan0 -o term.txt --sync-period-ms 10 --no-nmt --no-sdo 2>acq5.err &
acq=$!
sleep 1
kill -TERM $acq
wait $acq
rc=$?
check "exit after SIGTERM is 0 or 1 (no devices answered), got $rc" test "$rc" -le 1
check "stop requested logged" grep -q 'stop requested' acq5.err

echo "== 6. a full disk: clear error, exit 3, no broken record"
mkdir -p /mnt/small && mount -t tmpfs -o size=12k tmpfs /mnt/small
./sph_cansim -o full.log --theta-steps 6 --phi-steps 2 --stop-s 0.5 --move-s 0.2 --sync-period-ms 10 2>/dev/null
./sph_acquired --replay full.log -o /mnt/small/p.txt --sync-period-ms 10 2>acq6.err
rc=$?
grep -E 'error' acq6.err | sed 's/^/   /'
check "exit 3 on a full disk, got $rc" test "$rc" -eq 3
check "the message says why" grep -q 'No space left on device' acq6.err
check "every row in the file is whole" \
  awk '!/^#/ && NF != 5 {bad = 1} END {exit bad}' /mnt/small/p.txt
check "the file ends with a newline" test "$(tail -c 1 /mnt/small/p.txt | od -An -c | tr -d ' ')" = '\n'

echo "== 7. the daemon as CANopen master: silent devices started, identified, a reboot restarted"
candump -L vcan0 >bus7.log &
cd_pid=$!
# The devices power on pre-operational; node 1 reboots 4.5 s later. They answer the daemon's SYNC,
# which counts to 240 as their 1019h says.
"${SIM[@]}" --sync-source external --sync-period-ms 10 --sync-counter-max 240 --fault reboot:1@4.5 --record rec7.txt \
  2>sim7.err &
sim_pid=$!
sleep 1
MASTER=(--sync-period-ms 10 --sync-counter-max 240 --heartbeat-timeout-s 2.5)
./sph_acquired --iface vcan0 -o master.txt --can-log master.log "${MASTER[@]}" --duration-s 7 --nmt-stop-at-exit \
  2>acq7.err
rc=$?
sleep 0.3
kill $sim_pid 2>/dev/null; wait $sim_pid
kill $cd_pid 2>/dev/null; wait $cd_pid
grep -E 'boot-up|restarted|acquiring|gap|summary: frames|master:' acq7.err | head -12 | sed 's/^/   /'
line() { grep -n -m1 -F " $1" bus7.log | cut -d: -f1; }  # first line of a frame on the bus
first_pdo=$(grep -n -m1 -E ' 18[123]#' bus7.log | cut -d: -f1)
echo "   candump: boot-up of node 1 at line $(line 701#00), NMT start of node 1 at $(line 000#0101), first PDO at $first_pdo"
check "daemon stopped cleanly, exit $rc (0, or 1: the reboot's cycles)" test "$rc" -le 1
check "candump: the nodes' boot-up messages (700h + node, state 00)" \
  test -n "$(line 701#00)" -a -n "$(line 702#00)" -a -n "$(line 703#00)"
check "candump: SDO upload of 1018h:01 to node 1 (601#40 18 10 01 ...) and its expedited answer (581#43 ...)" \
  test -n "$(line 601#4018100100000000)" -a -n "$(line 581#4318100148505300)"
check "candump: segmented upload of 1008h, toggle bit 0 then 1 (601#60.., 601#70..)" \
  test -n "$(line 601#4008100000000000)" -a -n "$(line 581#4108100018000000)" -a \
  -n "$(line 601#6000000000000000)" -a -n "$(line 601#7000000000000000)"
check "candump: NMT Start remote node for nodes 1, 2, 3 (000#01 nn)" \
  test -n "$(line 000#0101)" -a -n "$(line 000#0102)" -a -n "$(line 000#0103)"
check "candump: no PDO before the NMT start (silent until started)" test "$first_pdo" -gt "$(line 000#0101)"
check "candump: NMT Stop remote node at exit (000#02 nn)" test -n "$(line 000#0201)" -a -n "$(line 000#0203)"
check "the rebooted node sent a second boot-up and was started again" \
  test "$(grep -c -F ' 701#00' bus7.log)" -eq 2 -a "$(grep -c -F ' 000#0101' bus7.log)" -eq 2
check "the daemon restarted it" grep -q 'node 1 (theta): restarted, operational again' acq7.err
check "the identity is in the points file's header" \
  grep -q '^# device_theta_encoder: node 1; name "sph_cansim theta encoder"; vendor_id 0x00535048;' master.txt
check "the gap is marked: start and end" \
  grep -q '^# gap start t_s .*: theta (node 1) rebooted' master.txt
check "... and its end" grep -q '^# gap end t_s .*: theta (node 1) sends again' master.txt
# Each row against what the simulator sent for the SYNC of its time (the nearest record, within
# 2 ms: under emulation the SYNCs come irregularly, some 1.4 ms apart).
read -r n7 unmatched bad < <(awk 'function abs(x) { return x < 0 ? -x : x }
  NR == FNR { if ($1 !~ /^#/ && $3 != "-" && $4 != "-" && $5 != "-") { m++; rt[m] = $1; rv[m] = $3 " " $4 " " $5 }
    next }
  !/^#/ { n++  # rows and records are both in time order: walk them together
    while (j < m && (j == 0 || abs(rt[j + 1] - $4) <= abs(rt[j] - $4))) j++
    if (j == 0 || abs(rt[j] - $4) >= 0.002) { unmatched++; next }
    if (rv[j] != $1 " " $2 " " $3) { bad++; print "row " $0 " | sent " rt[j] " " rv[j] > "bad7.txt" } }
  END { print n + 0, unmatched + 0, bad + 0 }' rec7.txt master.txt)
if [ -s bad7.txt ]; then  # what the daemon wrote and the simulator sent around each bad row
  grep -E 'lost:|SYNC counter' acq7.err | sed 's/^/   /'
  head -3 bad7.txt | while read -r _ th ph r t _; do
    echo "   row at t_s $t:"; grep -n -B3 -A1 -F " $t " master.txt | sed 's/^/     /'
    awk -v t="$t" '$1 !~ /^#/ && $1 > t - 0.025 && $1 < t + 0.025' rec7.txt | sed 's/^/     sent /'
  done
fi
echo "   rows $n7; without a record $unmatched; different from what was sent for their SYNC $bad"
check "rows around a reboot: $n7 (at least 300)" test "$n7" -ge 300
check "every row is what the devices sent for its SYNC: none misassigned" test "$unmatched" -eq 0 -a "$bad" -eq 0
./sph_acquired --replay master.log -o replay.txt "${MASTER[@]}" 2>replay7.err
rc=$?
grep -v -e '^# source: ' -e '^# started: ' master.txt >a7.txt
grep -v -e '^# source: ' -e '^# started: ' replay.txt >b7.txt
check "the replay of the frame log: exit $rc (0 or 1 as live)" test "$rc" -le 1
check "... gives the same points file ($(wc -l <a7.txt) lines; header source and start time aside)" cmp -s a7.txt b7.txt
cmp -s a7.txt b7.txt || diff a7.txt b7.txt | head -10 | sed 's/^/   /'
# candump's own log began before the daemon and ran on after it: the frames before its first
# request are left out; its last cycle may be complete in candump's log where the daemon had
# stopped reading (the last two lines of the daemon's file).
./sph_acquired --replay bus7.log -o candump.txt "${MASTER[@]}" 2>replay7c.err
grep -v -e '^# source: ' -e '^# started: ' candump.txt >c7.txt
keep=$(($(wc -l <a7.txt) - 2))
check "the replay of candump's log gives the same file, its last cycle aside" \
  cmp -s <(head -n "$keep" a7.txt) <(head -n "$keep" c7.txt)
cmp -s <(head -n "$keep" a7.txt) <(head -n "$keep" c7.txt) || diff a7.txt c7.txt | head -10 | sed 's/^/   /' 

echo "== 8. a wrong counts per revolution in the configuration refuses the start"
"${SIM[@]}" --sync-source external --sync-period-ms 10 2>sim8.err &
sim_pid=$!
sleep 1
candump -L vcan0 >bus8.log &
cd_pid=$!
sleep 0.2
./sph_acquired --iface vcan0 -o wrong.txt --sync-period-ms 10 --theta-counts-per-rev 8192 --duration-s 5 2>acq8.err
rc=$?
sleep 0.2
kill $cd_pid 2>/dev/null; wait $cd_pid
kill $sim_pid 2>/dev/null; wait $sim_pid
sed 's/^/   /' acq8.err
check "exit 5, got $rc" test "$rc" -eq 5
check "the message names node, object and both values" grep -q \
  'error: node 1 (theta): object 0x6001:00 (measuring units per revolution): the device has 16777216, --theta-counts-per-rev 8192' \
  acq8.err
check "candump: 6001h read (601#40 01 60 00 ...) and answered 2^24 (581#43 01 60 00 00 00 00 01)" \
  grep -q ' 581#4301600000000001' bus8.log
check "no node was started (no NMT Start on the bus)" test "$(grep -c -F ' 000#01' bus8.log)" -eq 0
check "no points file" test ! -e wrong.txt

echo "== 9. an event-driven TPDO: refused, then written to synchronous by --configure-pdo"
"${SIM[@]}" --sync-source external --sync-period-ms 10 --transmission-type 254 2>sim9.err &
sim_pid=$!
sleep 1
./sph_acquired --iface vcan0 -o event.txt --sync-period-ms 10 --duration-s 3 2>acq9a.err
rc_a=$?
candump -L vcan0 >bus9.log &
cd_pid=$!
sleep 0.2
./sph_acquired --iface vcan0 -o configured.txt --sync-period-ms 10 --duration-s 4 --configure-pdo 2>acq9b.err
rc_b=$?
sleep 0.2
kill $cd_pid 2>/dev/null; wait $cd_pid
kill $sim_pid 2>/dev/null; wait $sim_pid
grep -m1 'transmission type' acq9a.err | sed 's/^/   /'
check "without --configure-pdo: exit 5, got $rc_a" test "$rc_a" -eq 5
check "the message names the object and both values" grep -q \
  'node 1 (theta): object 0x1800:02 (TPDO1 transmission type): the device has 254 (event-driven, manufacturer-specific), the daemon needs 1' \
  acq9a.err
check "with --configure-pdo: exit $rc_b (0 or 1)" test "$rc_b" -le 1
check "candump: Enter pre-operational (000#80 01), then the COB-ID made invalid (601#23 00 18 01 81 01 00 80)" \
  test -n "$(grep -m1 -F ' 000#8001' bus9.log)" -a -n "$(grep -m1 -F ' 601#2300180181010080' bus9.log)"
check "candump: transmission type 1 written (601#2F 00 18 02 01) and confirmed (581#60 00 18 02)" \
  test -n "$(grep -m1 -F ' 601#2F00180201000000' bus9.log)" -a -n "$(grep -m1 -F ' 581#6000180200000000' bus9.log)"
check "... read back as 1 (581#4F 00 18 02 01)" grep -q -F ' 581#4F00180201000000' bus9.log
check "rows from the configured devices: $(rows configured.txt)" test "$(rows configured.txt)" -ge 150

echo "== 10. devices without heartbeat (1017h = 0): given one, and operational only when it says so"
"${SIM[@]}" --sync-source external --sync-period-ms 10 --heartbeat-period-s 0 2>sim10.err &
sim_pid=$!
sleep 1
candump -L vcan0 >bus10.log &
cd_pid=$!
sleep 0.2
./sph_acquired --iface vcan0 -o heartbeat.txt --sync-period-ms 10 --duration-s 3 2>acq10.err
rc=$?
sleep 0.2
kill $cd_pid 2>/dev/null; wait $cd_pid
kill $sim_pid 2>/dev/null; wait $sim_pid
grep -E 'operational|heartbeat' acq10.err | head -5 | sed 's/^/   /'
start10=$(grep -n -m1 -F ' 000#0101' bus10.log | cut -d: -f1)
op10=$(awk -v s="${start10:-0}" 'NR > s && / 701#05$/ {print NR; exit}' bus10.log)
check "daemon stopped cleanly, exit $rc (0 or 1)" test "$rc" -le 1
check "candump: 1017h read as 0 ms (581#4B 17 10 00 00 00)" grep -q -F ' 581#4B17100000000000' bus10.log
check "candump: 100 ms written (601#2B 17 10 00 64 00) and confirmed (581#60 17 10 00)" \
  test -n "$(grep -m1 -F ' 601#2B17100064000000' bus10.log)" -a -n "$(grep -m1 -F ' 581#6017100000000000' bus10.log)"
check "candump: node 1's heartbeat says operational (701#05, line ${op10:-none}) after its NMT Start (line ${start10:-none})" \
  test -n "$op10"
check "the daemon calls the nodes operational because their heartbeats say so" \
  grep -q 'every node is operational (each heartbeat says so)' acq10.err
check "rows: $(rows heartbeat.txt)" test "$(rows heartbeat.txt)" -ge 100

echo "== 11. a counted SYNC against devices whose 1019h is 0: refused, then 1019h configured by the daemon"
"${SIM[@]}" --sync-source external --sync-period-ms 10 --nodes-sync-counter-max 0 2>sim11.err &
sim_pid=$!
sleep 1
./sph_acquired --iface vcan0 -o uncounted.txt --sync-period-ms 10 --sync-counter-max 240 --duration-s 3 2>acq11a.err
rc_a=$?
candump -L vcan0 >bus11.log &
cd_pid=$!
sleep 0.2
./sph_acquired --iface vcan0 -o counted.txt --sync-period-ms 10 --sync-counter-max 240 --duration-s 4 --configure-pdo \
  2>acq11b.err
rc_b=$?
sleep 0.2
kill $cd_pid 2>/dev/null; wait $cd_pid
kill $sim_pid 2>/dev/null; wait $sim_pid
grep -m1 '0x1019' acq11a.err | sed 's/^/   /'
check "without --configure-pdo: exit 5, got $rc_a" test "$rc_a" -eq 5
check "the message names node, object and both values" grep -q \
  'error: node 1 (theta): object 0x1019:00 (synchronous counter overflow value): the device has 0, --sync-counter-max 240' \
  acq11a.err
check "no points file" test ! -e uncounted.txt
check "with --configure-pdo: exit $rc_b (0 or 1)" test "$rc_b" -le 1
check "candump: 1019h = 240 written (601#2F 19 10 00 F0), confirmed (581#60 19 10 00), read back (581#4F 19 10 00 F0)" \
  test -n "$(grep -m1 -F ' 601#2F191000F0000000' bus11.log)" -a -n "$(grep -m1 -F ' 581#6019100000000000' bus11.log)" \
  -a -n "$(grep -m1 -F ' 581#4F191000F0000000' bus11.log)"
check "candump: counted SYNCs (080#01, 080#02, ...)" test -n "$(grep -m1 -F ' 080#01' bus11.log)"
check "candump: no EMCY 0x8240 (unexpected SYNC length) from any node" test -z "$(grep -m1 -E ' 08[123]#4082' bus11.log)"
check "rows from the configured devices: $(rows counted.txt)" test "$(rows counted.txt)" -ge 150

echo "== 12. nodes dropped to pre-operational mid-run (another sender's NMT, a simulated error): started again"
candump -L vcan0 >bus12.log &
cd_pid=$!
# Node 2 has a communication error 4 s after power-on (EMCY 0x8100, error register 0x11,
# pre-operational, cleared 1 s later); node 3 is sent Enter pre-operational by another sender.
"${SIM[@]}" --sync-source external --sync-period-ms 10 --heartbeat-period-s 0.2 --fault error:2@4 2>sim12.err &
sim_pid=$!
sleep 1
./sph_acquired --iface vcan0 -o left.txt --sync-period-ms 10 --duration-s 7 2>acq12.err &
acq=$!
sleep 4.5
cansend vcan0 000#8003
wait $acq
rc=$?
sleep 0.2
kill $sim_pid 2>/dev/null; wait $sim_pid
kill $cd_pid 2>/dev/null; wait $cd_pid
after() {  # after LINE FRAME: the first line after LINE with FRAME
  awk -v s="$1" -v f=" $2" 'NR > s && index($0, f) {print NR; exit}' bus12.log
}
other=$(grep -n -m1 -F ' 000#8003' bus12.log | cut -d: -f1)
hb3=$(after "${other:-0}" '703#7F')
start3=$(after "${hb3:-0}" '000#0103')
op3=$(after "${start3:-0}" '703#05')
echo "   candump, node 3:"
for l in $other $hb3 $start3 $op3; do sed -n "${l}p" bus12.log | sed 's/^/     /'; done
emcy2=$(grep -n -m1 -F ' 082#0081' bus12.log | cut -d: -f1)
reset2=$(grep -n -m1 -F ' 082#0000' bus12.log | cut -d: -f1)
start2=$(after "${reset2:-0}" '000#0102')
op2=$(after "${start2:-0}" '702#05')
echo "   candump, node 2:"
for l in $emcy2 $(after "${emcy2:-0}" '000#0102') $reset2 $start2 $op2; do sed -n "${l}p" bus12.log | sed 's/^/     /'; done
grep -E 'left operational|restarted|not operational yet|EMCY' acq12.err | head -8 | sed 's/^/   /'
echo "   the points file around it:"
grep -n -E '^# (node state|gap|EMCY|error state)' left.txt | head -12 | sed 's/^/     /'
rows3=$(awk '/node 3 \(probe\): operational \(was pre-operational\)/ {on = 1; next} on && !/^#/ {n++} END {print n + 0}' left.txt)
rows2=$(awk '/node 2 \(phi\): operational \(was pre-operational\)/ {on = 1; next} on && !/^#/ {n++} END {print n + 0}' left.txt)
check "daemon stopped cleanly, exit $rc (0, or 1: the cycles without the nodes)" test "$rc" -le 1
check "candump: another sender's Enter pre-operational (000#80 03), node 3's heartbeat 7F, the daemon's Start (000#01 03), 05" \
  test -n "$other" -a -n "$hb3" -a -n "$start3" -a -n "$op3"
check "candump: node 2's EMCY 0x8100, its error reset (082#00 00), the daemon's Start after it, 702#05" \
  test -n "$emcy2" -a -n "$reset2" -a -n "$start2" -a -n "$op2"
check "the daemon said so" grep -q 'node 3 (probe): restarted, operational again' acq12.err
check "... for node 2 too" grep -q 'node 2 (phi): restarted, operational again' acq12.err
check "the points file: node 3 left operational, a gap, and back" \
  grep -q '^# gap start t_s .*: probe (node 3) left operational (pre-operational)' left.txt
check "the points file: node 2's EMCY and its error state, start and end" \
  test -n "$(grep -m1 '^# EMCY t_s .*: phi node 2: EMCY 0x8100' left.txt)" -a \
  -n "$(grep -m1 '^# error state end t_s .*: node 2 (phi): error reset (EMCY 0x0000)' left.txt)"
check "rows after node 3 was back: $rows3 (about 250)" test "$rows3" -ge 150
check "rows after node 2 was back: $rows2" test "$rows2" -ge 100

echo "== 13. a REAL32 probe"
REAL=(--probe-data-type real32 --probe-scale-um-per-count 1000)
"${SIM[@]}" --sync-source external --sync-period-ms 10 "${REAL[@]}" --record rec13.txt 2>sim13.err &
sim_pid=$!
sleep 1
candump -L vcan0 >bus13.log &
cd_pid=$!
sleep 0.2
./sph_acquired --iface vcan0 -o real.txt --sync-period-ms 10 --duration-s 4 "${REAL[@]}" --probe-pdo-object 0x2000:00 \
  2>acq13.err
rc=$?
sleep 0.2
kill $cd_pid 2>/dev/null; wait $cd_pid
kill $sim_pid 2>/dev/null; wait $sim_pid
n13=$(rows real.txt)
bad13=$(awk 'function abs(x) { return x < 0 ? -x : x }
  NR == FNR { if ($1 !~ /^#/ && $5 != "-") { m++; rt[m] = $1; rr[m] = $5 } next }
  !/^#/ { while (j < m && (j == 0 || abs(rt[j + 1] - $4) <= abs(rt[j] - $4))) j++
    if (j == 0 || abs(rt[j] - $4) >= 0.002 || rr[j] != $3) bad++ }
  END { print bad + 0 }' rec13.txt real.txt)
echo "   a probe frame: $(grep -m1 -E ' 183#' bus13.log); a row: $(grep -m1 -v '^#' real.txt)"
check "daemon stopped cleanly, exit $rc (0 or 1)" test "$rc" -le 1
check "candump: the mapped object 0x2000:00 read over SDO, 4 bytes (583#43 00 20 00 ...)" \
  grep -q -E ' 583#43002000' bus13.log
check "rows of the REAL32 probe: $n13" test "$n13" -ge 200
check "each row's r is the value the probe sent for its SYNC: $bad13 different" test "$bad13" -eq 0

echo "== 14. a segmented download to a 16-byte object; a TPDO made invalid while operational"
"${SIM[@]}" --sync-source external --sync-period-ms 10 2>sim14.err &
sim_pid=$!
sleep 0.5
candump -L vcan0 >bus14.log &
cd_pid=$!
sleep 0.2
for f in 601#2100210010000000 601#006C616220332C20 601#1062656E63682032 601#0B20200000000000 \
  601#4000210000000000 601#6000000000000000 601#7000000000000000 601#6000000000000000; do
  cansend vcan0 "$f"
  sleep 0.05
done
cansend vcan0 000#0100
sleep 0.1
for f in 080# 080# 601#2300180181010080 080# 080#; do  # the first SYNC starts the simulated pattern
  cansend vcan0 "$f"
  sleep 0.05
done
sleep 0.2
kill $cd_pid 2>/dev/null; wait $cd_pid
kill $sim_pid 2>/dev/null; wait $sim_pid
grep -E ' 60[1]#| 58[1]#| 18[123]#| 080#' bus14.log | sed 's/^/   /'
sdo() { grep -A3 -F " 601#$1" bus14.log | grep -q -F " 581#$2"; }
check "initiate (21: segmented, size 16) answered 60" sdo 2100210010000000 6000210000000000
check "segment toggle 0 answered 20, toggle 1 answered 30, the last (0B: 2 bytes, c) answered 20" \
  eval 'sdo 006C616220332C20 2000000000000000 && sdo 1062656E63682032 3000000000000000 && sdo 0B20200000000000 2000000000000000'
check "read back: 16 bytes, 'lab 3, ' 'bench 2' '  ' (the last segment: 0B)" \
  eval 'sdo 4000210000000000 4100210010000000 && sdo 6000000000000000 006C616220332C20 &&
    sdo 7000000000000000 1062656E63682032 && grep -q -F " 581#0B20200000000000" bus14.log'
pdo_before=$(awk '/ 601#2300180181010080/ {exit} / 181#/ {n++} END {print n + 0}' bus14.log)
pdo_after=$(awk '/ 601#2300180181010080/ {on = 1} on && / 181#/ {n++} END {print n + 0}' bus14.log)
others_after=$(awk '/ 601#2300180181010080/ {on = 1} on && / 18[23]#/ {n++} END {print n + 0}' bus14.log)
check "COB-ID 0x80000181 written while operational (581#60 00 18 01)" sdo 2300180181010080 6000180100000000
check "node 1's PDO before ($pdo_before), none after ($pdo_after); the other nodes' go on ($others_after)" \
  test "$pdo_before" -ge 1 -a "$pdo_after" -eq 0 -a "$others_after" -ge 2

echo "== 15. a start refused after NMT Start leaves the bus as found"
# Node 2 rebooted without its settings before the daemon began: 1017h 0 and an error, so NMT Start
# cannot make it operational; the daemon gives it a heartbeat (1017h 100 ms), starts every node,
# and refuses the start.
"${SIM[@]}" --sync-source external --sync-period-ms 10 --fault settings-lost:2@0.2 2>sim15.err &
sim_pid=$!
sleep 1
candump -L vcan0 >bus15.log &
cd_pid=$!
sleep 0.2
./sph_acquired --iface vcan0 -o refused.txt --sync-period-ms 10 --duration-s 4 2>acq15.err
rc=$?
sleep 1.5
kill $cd_pid 2>/dev/null; wait $cd_pid
kill $sim_pid 2>/dev/null; wait $sim_pid
grep -E 'refused|leaving the bus' acq15.err | sed 's/^/   /'
undo=$(grep -n -m1 -F ' 000#8001' bus15.log | cut -d: -f1)
echo "   candump after the refusal:"; sed -n "${undo:-1},+5p" bus15.log | sed 's/^/     /'
check "exit 5, got $rc" test "$rc" -eq 5
check "candump: the nodes started go back to pre-operational (000#80 01, 000#80 03)" \
  test -n "$undo" -a -n "$(grep -m1 -F ' 000#8003' bus15.log)"
check "candump: node 2's 1017h written back to 0 (602#2B 17 10 00 00 00)" grep -q -F ' 602#2B17100000000000' bus15.log
check "candump: node 1's last heartbeat says pre-operational (701#7F)" \
  test "$(grep -F ' 701#' bus15.log | tail -1 | sed 's/.*#//')" = 7F
check "no points file" test ! -e refused.txt

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
