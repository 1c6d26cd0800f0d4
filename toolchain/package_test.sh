#!/usr/bin/env bash
# Package test: builds the firmware's Debian package in BUILD_DIR, installs it into a
# temporary root directory with toolchain/deploy, runs the installed firmware (under qemu-user
# for Arm): the service ships unconfigured (--check-config refuses it and names the guide; the
# demo table is not the service's table and drives no real device), config and table checks, a
# dry run, a table update, a refused table (nothing changed) and a forced rollback when the
# installed table is refused at start.
# Usage: toolchain/package_test.sh BUILD_DIR   (build/, build-aarch64/ or build-armhf/)
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:?usage: package_test.sh BUILD_DIR}"
fail() { echo "package_test: FAIL: $*" >&2; exit 1; }

cmake --build "$build" --target mrd-firmware mrd_default_table >/dev/null
rm -f "$build"/mrd-firmware_*.deb
(cd "$build" && cpack -G DEB >/dev/null)
deb="$(ls "$build"/mrd-firmware_*.deb)"
echo "package: $deb ($(dpkg-deb -f "$deb" Architecture), depends: $(dpkg-deb -f "$deb" Depends))"
contents="$(dpkg-deb -c "$deb")"
for f in ./usr/bin/mrd-firmware ./etc/mrd/firmware.toml ./usr/share/mrd/demo-table.bin \
         ./usr/share/doc/mrd-firmware/devices.md ./usr/share/doc/mrd-firmware/firmware_config.md \
         ./usr/share/doc/mrd-firmware/logging.md \
         ./lib/systemd/system/mrd-firmware.service; do
  grep -q " $f\$" <<<"$contents" || fail "package lacks $f"
done
! grep -q " ./var/lib/mrd/table.bin\$" <<<"$contents" || fail "package installs the demo table"

root="$(mktemp -d)"
trap 'rm -rf "$root"' EXIT
bash toolchain/deploy --root "$root" --package "$deb"
unit="$root/lib/systemd/system/mrd-firmware.service"
for key in Type=notify CPUSchedulingPolicy=fifo CPUSchedulingPriority= LimitMEMLOCK=infinity \
           Restart=on-failure RestartPreventExitStatus=2 WatchdogSec= \
           "ExecStartPre=/usr/bin/mrd-firmware --check-config" \
           "--check-table /var/lib/mrd/table.bin --config /etc/mrd/firmware.toml --rollback"; do
  grep -q -- "$key" "$unit" || fail "unit lacks $key"
done
# Boot order: the unit waits for the config's CAN interface (bounded, before the firmware
# opens it) and its retries never reach systemd's start limit (which would leave it failed on
# a board whose CAN comes up late): no limit, and a retry delay that, with the wait, keeps the
# attempts far apart.
key() { sed -n "s/^$1=//p" "$unit"; }
[ "$(key StartLimitIntervalSec)" = 0 ] || fail "unit has a start limit: StartLimitIntervalSec=$(key StartLimitIntervalSec)"
pre="$(key ExecStartPre)"
grep -q -- "--wait-for-bus /etc/mrd/firmware.toml --timeout [0-9]" <<<"$pre" ||
  fail "unit does not wait for its CAN interface: $pre"
wait_line="$(grep -n -- "^ExecStartPre=.*--wait-for-bus" "$unit" | cut -d: -f1)"
start_line="$(grep -n "^ExecStart=" "$unit" | cut -d: -f1)"
[ "$wait_line" -lt "$start_line" ] || fail "the bus wait does not come before ExecStart"
rs="$(key RestartSec | tr -d s)"
[ "${rs%%.*}" -ge 5 ] || fail "RestartSec=$rs s: restarts too fast"
grep -q "^After=.*network.target" "$unit" || fail "unit not ordered after network.target"
if command -v systemd-analyze >/dev/null; then
  # systemd's own reading of the unit (unknown keys, bad values); the binary it names is
  # the installed one, checked below.
  sed "s|/usr/bin/mrd-firmware|$root/usr/bin/mrd-firmware|g" "$unit" >"$root/check.service"
  verify="$(systemd-analyze verify "$root/check.service" 2>&1 | grep -v "Cannot add dependency\|command .* is not executable\|Failed to put bus name" || true)"
  [ -z "$verify" ] || fail "systemd-analyze verify: $verify"
fi

# An Arm package runs under qemu-user with the build's target sysroot as the library prefix
# (toolchain/sysroot.sh: the board's libc, libmodbus, libgpiod and toml++).
fw=("$root/usr/bin/mrd-firmware")
sysroot="$(sed -n 's/^MRD_SYSROOT:PATH=//p' "$build/CMakeCache.txt")"
[ -z "$sysroot" ] || export MRD_SYSROOT="$sysroot"  # toolchain/deploy runs it likewise
case "$(od -An -tx1 -j18 -N1 "${fw[0]}" | tr -d ' ')" in
  b7) [ "$(uname -m)" = aarch64 ] || fw=(qemu-aarch64 -L "$sysroot" "${fw[@]}") ;;
  28) [ "$(uname -m)" = armv7l ] || fw=(qemu-arm -L "$sysroot" "${fw[@]}") ;;
esac
cfg="$root/etc/mrd/firmware.toml"
dest="$root/var/lib/mrd/table.bin"
demo="$root/usr/share/mrd/demo-table.bin"

# Unconfigured: the unit's ExecStartPre refuses the shipped config (exit 2: no restart loop)
# and says where the guide is.
rc=0; "${fw[@]}" --check-config "$cfg" >/dev/null 2>"$root/err" || rc=$?
[ "$rc" = 2 ] || fail "unconfigured config: exit $rc, want 2"
grep -q "no device profile configured.*/usr/share/doc/mrd-firmware/devices.md" "$root/err" ||
  fail "unconfigured config: no pointer to the guide: $(cat "$root/err")"
echo "unconfigured: $(head -c 160 "$root/err")"
# The demo table drives no real device unless told otherwise.
printf '[can]\ninterface = "can0"\ninputs = ["velocity", "demand"]\noutputs = ["command"]\n' \
  >"$root/can0.toml"
"${fw[@]}" --check-config "$root/can0.toml" >/dev/null || fail "configured config refused"
rc=0; "${fw[@]}" --table "$demo" --config "$root/can0.toml" --duration 0.1 2>"$root/err" || rc=$?
if [ "$rc" != 2 ] || ! grep -q "demo table" "$root/err"; then
  fail "demo table not refused on can0 (exit $rc): $(cat "$root/err")"
fi
echo "demo table on can0: refused"

# The bus wait names the interface it waits for and fails (exit 1: the unit retries, exit 2
# would stop it) when it does not come up; an interface that is up passes at once.
printf '[can]\ninterface = "mrdnosuch0"\ninputs = ["velocity", "demand"]\noutputs = ["command"]\n' \
  >"$root/missing.toml"
rc=0; "${fw[@]}" --wait-for-bus "$root/missing.toml" --timeout 0.5 >/dev/null 2>"$root/err" || rc=$?
[ "$rc" = 1 ] || fail "wait for a missing interface: exit $rc, want 1"
grep -q "CAN interface mrdnosuch0 is not up after 0.5 s" "$root/err" ||
  fail "wait does not name the interface: $(cat "$root/err")"
sed 's/mrdnosuch0/lo/' "$root/missing.toml" >"$root/lo.toml"
"${fw[@]}" --wait-for-bus "$root/lo.toml" --timeout 5 >/dev/null || fail "wait for an up interface failed"
echo "bus wait: $(head -c 120 "$root/err")"

# The user installs a table (here: the demo one, for the test) and it is checked.
bash toolchain/deploy --root "$root" --table "$demo" >/dev/null
"${fw[@]}" --check-table "$dest" --config "$cfg" >/dev/null || fail "installed table refused"
# The shipped config logs into /var/log/mrd: here into the test root instead (--log).
out="$("${fw[@]}" --table "$dest" --config "$cfg" --dry-run 1 --lockstep --json \
  --log "$root/periods.mrdlog")" || fail "dry run failed: $out"
grep -q '"ticks": 1000,' <<<"$out" || fail "dry run did not run 1000 ticks: $out"
grep -q '"records_written": 1000, "dropped": 0' <<<"$out" || fail "per-period log: $out"
grep -q "\"safe_entries\": 0," <<<"$out" || fail "dry run entered the safe state: $out"
grep -q "\"final_safe_state\": true" <<<"$out" || fail "driver not left in the safe state: $out"
echo "dry run: 1000 ticks at 1 kHz, installed table and config"

# Table update: a table written by the installed firmware, installed with deploy.
"${fw[@]}" --write-table "$root/new.bin"
before="$(sha256sum <"$dest")"
bash toolchain/deploy --root "$root" --table "$root/new.bin" >/dev/null
cmp -s "$dest" "$root/new.bin" || fail "table not installed"
[ "$(sha256sum <"$dest.prev")" = "$before" ] || fail "previous table not kept"
! compgen -G "$dest*.tmp-*" >/dev/null || fail "staging file left behind"
echo "table update: installed, previous kept as table.bin.prev"

# A corrupt table is refused by deploy and changes nothing.
cp "$root/new.bin" "$root/bad.bin"
printf '\x5a' | dd of="$root/bad.bin" bs=1 seek=100 conv=notrunc status=none
if bash toolchain/deploy --root "$root" --table "$root/bad.bin" 2>"$root/err"; then
  fail "corrupt table accepted"
fi
grep -q "error: table .* refused" "$root/err" || fail "no reason given: $(cat "$root/err")"
cmp -s "$dest" "$root/new.bin" || fail "refused table changed the installed one"
echo "corrupt table: refused ($(head -c 120 "$root/err"))"

# Forced rollback: the installed table is damaged, the unit's ExecStartPre refuses it at start
# and rolls back to table.bin.prev; the firmware then runs on the previous table.
printf '\x5a' | dd of="$dest" bs=1 seek=64 conv=notrunc status=none
"${fw[@]}" --check-table "$dest" --config "$cfg" >/dev/null 2>&1 && fail "damaged table accepted"
"${fw[@]}" --check-table "$dest" --config "$cfg" --rollback >/dev/null 2>"$root/err" ||
  fail "rollback failed: $(cat "$root/err")"
grep -q "rolled back" "$root/err" || fail "rollback not reported"
[ "$(sha256sum <"$dest")" = "$before" ] || fail "rollback did not restore the previous table"
[ -e "$dest.refused" ] || fail "refused table not kept"
"${fw[@]}" --table "$dest" --config "$cfg" --dry-run 0.2 --lockstep \
  --log "$root/periods.mrdlog" >/dev/null ||
  fail "dry run after rollback failed"
echo "forced rollback: damaged table refused at start, previous table restored, dry run ok"
echo "package_test: ok"
