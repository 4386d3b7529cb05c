#!/usr/bin/env bash
# run-in-vcan-vm.sh: run a host-built program of this project inside a throw-away QEMU VM that has
# a real Linux CAN stack (Debian's linux-image-amd64 with can, can-raw and vcan loaded; vcan0 up),
# because the build machines' own kernels have no CAN support.
#
# Usage: tests/vm/run-in-vcan-vm.sh [-f FILE]... [-t SEC] [--cache DIR] [--] PROGRAM [ARGS...]
#   -f FILE     copy FILE into the VM's /work as well (ELF files bring their shared libraries)
#   -t SEC      wall-clock limit for the VM (default 300)
#   --cache DIR kernel extract and base image cache (default $SPH_VCAN_VM_CACHE or /tmp/sph-vcan-vm)
#
# Inside the VM PROGRAM runs as root in /work with busybox, bash, iproute2's ip (/usr/sbin/ip) and
# can-utils on PATH. Its output (stdout and stderr) is printed here; its exit status is ours.
# Exit 77: the VM cannot run on this host (no qemu-system-x86_64 and no way to install it, no
# kernel package); the reason is printed. Exit 124: timeout. Exit 125: the VM gave no status.
#
# Boot path: the kernel's uncompressed vmlinux is booted through PVH (CONFIG_PVH) under TCG
# (software emulation; about 5 s to the program on 2 cores), from a busybox initramfs. Serial
# ports: ttyS0 kernel console, ttyS1 program output, ttyS2 exit status.
set -euo pipefail

CACHE=${SPH_VCAN_VM_CACHE:-/tmp/sph-vcan-vm}
TIMEOUT=300
FILES=()
FORMAT=1   # bump when the base image layout changes

skip() { echo "vcan-vm: SKIPPED: $*"; exit 77; }
die() { echo "vcan-vm: error: $*" >&2; exit 125; }
log() { echo "vcan-vm: $*" >&2; }

while [[ $# -gt 0 ]]; do
  case $1 in
    -f) FILES+=("$2"); shift 2 ;;
    -t) TIMEOUT=$2; shift 2 ;;
    --cache) CACHE=$2; shift 2 ;;
    --) shift; break ;;
    -*) echo "unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done
[[ $# -ge 1 ]] || { echo "usage: $0 [-f FILE]... [-t SEC] PROGRAM [ARGS...]" >&2; exit 2; }
PROG=$1; shift
[[ -x $PROG ]] || die "not an executable: $PROG"
mkdir -p "$CACHE"
exec 9>"$CACHE/.lock"
flock 9   # one cache builder and apt-get at a time

# --- host packages (Debian): installed when missing and we are root
need=()
command -v qemu-system-x86_64 >/dev/null || need+=(qemu-system-x86)
[[ -x /bin/busybox ]] || need+=(busybox-static)
command -v cpio >/dev/null || need+=(cpio)
command -v xz >/dev/null || need+=(xz-utils)
command -v modinfo >/dev/null || need+=(kmod)
command -v cansend >/dev/null || need+=(can-utils)
[[ -x /usr/sbin/ip ]] || need+=(iproute2)
if ((${#need[@]})); then
  [[ $EUID -eq 0 ]] || skip "missing ${need[*]} and not root to install them"
  log "apt-get install ${need[*]}"
  export DEBIAN_FRONTEND=noninteractive
  { apt-get install -y -qq --no-install-recommends "${need[@]}" ||
      { apt-get update -qq && apt-get install -y -qq --no-install-recommends "${need[@]}"; }; } >"$CACHE/apt.log" 2>&1 ||
    skip "apt-get install ${need[*]} failed (see $CACHE/apt.log)"
fi
command -v qemu-system-x86_64 >/dev/null || skip "qemu-system-x86_64 is not available"

is_elf() { [[ -f $1 && $(head -c 4 "$1" | od -An -c | tr -d ' \n') == '177ELF' ]]; }
# Copies the shared libraries of ELF files into ROOT at the same paths.
copy_libs() {
  local root=$1 f lib; shift
  for f in "$@"; do
    is_elf "$f" || continue
    for lib in $(ldd "$f" 2>/dev/null | awk '$2 == "=>" && $3 ~ /^\// {print $3} $1 ~ /^\// {print $1}'); do
      [[ -e $root$lib ]] || { mkdir -p "$root$(dirname "$lib")"; cp -L "$lib" "$root$lib"; }
    done
  done
}

# --- kernel: Debian's linux-image-amd64 (cloud kernels lack CONFIG_CAN), extracted once
KDIR=$CACHE/kernel
if [[ ! -s $KDIR/ok ]]; then
  pkg=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ {print $2; exit}')
  if [[ -z $pkg ]]; then apt-get update -qq >/dev/null 2>&1 || true
    pkg=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ {print $2; exit}'); fi
  [[ -n $pkg ]] || skip "cannot resolve the Debian package linux-image-amd64 (no apt lists)"
  log "fetching kernel $pkg (about 70 MB, once)"
  rm -rf "$KDIR"; mkdir -p "$KDIR/modules"
  tmp=$(mktemp -d "$CACHE/tmp.XXXXXX"); chmod 755 "$tmp"
  (cd "$tmp" && apt-get download "$pkg" >"$CACHE/download.log" 2>&1) || skip "apt-get download $pkg failed"
  dpkg-deb -x "$tmp"/*.deb "$tmp/x"
  mroot=$tmp/x/lib/modules; [[ -d $mroot ]] || mroot=$tmp/x/usr/lib/modules
  kver=$(ls "$mroot" | head -1)
  # vmlinux from the bzImage: the xz stream after its magic (PVH boot skips decompression in TCG)
  bz=$tmp/x/boot/vmlinuz-$kver
  while IFS=: read -r off _; do
    tail -c +$((off + 1)) "$bz" | xz -dc --single-stream >"$KDIR/vmlinux" 2>/dev/null || true
    is_elf "$KDIR/vmlinux" && break
  done < <(LC_ALL=C grep -abo $'\xfd7zXZ\x00' "$bz" | head -5)
  is_elf "$KDIR/vmlinux" || { rm -f "$KDIR/vmlinux"; cp "$bz" "$KDIR/vmlinuz"; }
  # modules in load order (the .deb has no modules.dep): can-dev before vcan, can before can-raw
  for m in can can-raw can-dev vcan; do
    f=$(find "$mroot/$kver" -name "${m}.ko*" | head -1)
    [[ -n $f ]] || die "module $m not in $pkg"
    case $f in *.ko) cp "$f" "$KDIR/modules/" ;; *.xz) xz -dc "$f" >"$KDIR/modules/$m.ko" ;; esac
    echo "$m.ko" >>"$KDIR/modules/order"
  done
  rm -rf "$tmp"
  echo "$pkg" >"$KDIR/ok"
fi

# --- base initramfs: busybox, bash, ip, can-utils, modules, /init (cached)
BASE=$CACHE/base-$FORMAT.cpio
if [[ ! -s $BASE ]]; then
  log "building the base initramfs"
  tmp=$(mktemp -d "$CACHE/tmp.XXXXXX"); root=$tmp/root
  mkdir -p "$root"/{bin,sbin,usr/bin,usr/sbin,dev,proc,sys,tmp,root,work,etc,lib/modules}
  chmod 1777 "$root/tmp"
  cp /bin/busybox "$root/bin/busybox"
  for a in $(/bin/busybox --list-full); do [[ -e $root/$a ]] || ln -s /bin/busybox "$root/$a"; done
  rm -f "$root/bin/ip" "$root/sbin/ip" "$root/usr/bin/ip" "$root/usr/sbin/ip"
  cp -L /usr/sbin/ip "$root/usr/sbin/ip"; copy_libs "$root" /usr/sbin/ip
  rm -f "$root/bin/bash"; cp -L /bin/bash "$root/bin/bash"; copy_libs "$root" /bin/bash
  for f in cansend candump cangen canplayer log2asc; do
    cp -L "$(command -v $f)" "$root/usr/bin/"; copy_libs "$root" "$(command -v $f)"
  done
  cp "$KDIR"/modules/* "$root/lib/modules/"
  printf 'root:x:0:0:root:/root:/bin/sh\n' >"$root/etc/passwd"; printf 'root:x:0:\n' >"$root/etc/group"
  cat >"$root/init" <<'INIT'
#!/bin/sh
export PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root
mount -t proc proc /proc; mount -t sysfs sysfs /sys; mount -t devtmpfs devtmpfs /dev
ln -sf /proc/self/fd /dev/fd
for t in ttyS1 ttyS2; do stty -F /dev/$t raw -echo 2>/dev/null; done
for m in $(cat /lib/modules/order); do insmod /lib/modules/$m || echo "insmod $m failed"; done
/usr/sbin/ip link set lo up
/usr/sbin/ip link add dev vcan0 type vcan && /usr/sbin/ip link set vcan0 up || echo "no vcan0"
cd /work
/work/run.sh </dev/null >/dev/ttyS1 2>&1
echo "exit:$?" >/dev/ttyS2
poweroff -f
INIT
  chmod 755 "$root/init"
  (cd "$root" && find . | LC_ALL=C sort | cpio -o -H newc -R 0:0 --quiet) >"$tmp/base.cpio"
  mv "$tmp/base.cpio" "$BASE"; rm -rf "$tmp"
fi
flock -u 9

# --- per run: the program, its files and libraries
RUN=$(mktemp -d "${TMPDIR:-/tmp}/sph-vcan-run.XXXXXX")
QPID=""
trap '[[ -n $QPID ]] && kill $QPID 2>/dev/null; rm -rf "$RUN"' EXIT
mkdir -p "$RUN/app/work"
cp -L "$PROG" "$RUN/app/work/"
elfs=("$PROG")
for f in "${FILES[@]}"; do cp -L "$f" "$RUN/app/work/"; is_elf "$f" && elfs+=("$f"); done
copy_libs "$RUN/app" "${elfs[@]}"
{
  echo '#!/bin/sh'
  echo 'export VCAN_VM=1'
  printf 'exec /work/%q' "$(basename "$PROG")"
  for a in "$@"; do printf ' %q' "$a"; done
  echo
} >"$RUN/app/work/run.sh"
chmod 755 "$RUN/app/work/run.sh"
(cd "$RUN/app" && find . | LC_ALL=C sort | cpio -o -H newc -R 0:0 --quiet) >"$RUN/app.cpio"
cat "$BASE" "$RUN/app.cpio" >"$RUN/initrd"
KERNEL=$KDIR/vmlinux; [[ -s $KERNEL ]] || KERNEL=$KDIR/vmlinuz
: >"$RUN/out"; : >"$RUN/status"
t0=$(date +%s.%N)
timeout --kill-after=10 "$TIMEOUT" qemu-system-x86_64 -accel tcg -cpu max -machine pc -m 256 -smp 1 \
  -nodefaults -nic none -display none -monitor none -no-reboot \
  -serial "file:$RUN/console" -serial "file:$RUN/out" -serial "file:$RUN/status" \
  -kernel "$KERNEL" -initrd "$RUN/initrd" -append "console=ttyS0 panic=-1 quiet loglevel=3 rdinit=/init" \
  >"$RUN/qemu.log" 2>&1 &
QPID=$!
tail -c +1 -f --pid=$QPID "$RUN/out" &
set +e; wait $QPID; qrc=$?; set -e
QPID=""
sleep 0.2
log "VM ran $(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN {printf "%.1f", b - a}') s (TCG)"
status=$(tr -d '\r\0' <"$RUN/status" | head -1)
case $status in exit:*) exit "${status#exit:}" ;; esac
[[ $qrc -eq 124 || $qrc -eq 137 ]] && { echo "vcan-vm: timed out after $TIMEOUT s" >&2; exit 124; }
if grep -q "Could not access KVM\|failed to initialize" "$RUN/qemu.log"; then skip "qemu cannot start: $(head -c 300 "$RUN/qemu.log")"; fi
echo "vcan-vm: no exit status from the VM (qemu rc $qrc): $(head -c 500 "$RUN/qemu.log")" >&2
tail -20 "$RUN/console" >&2
exit 125
