#!/bin/sh
# /init of the virtual board (make_initramfs.sh): mounts, vcan0, a gpio-sim chip through
# configfs, candump in the background, the scenario with mrd-hil run (the firmware on CAN_RAW
# over vcan0 and libgpiod on the gpio-sim chip), the result and the bus log between markers
# on the console, power-off (PSCI: QEMU exits). Every path ends in the power-off.
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /tmp
mount -t configfs configfs /sys/kernel/config
echo "VBOARD-CLOCK start uptime=$(cut -d' ' -f1 /proc/uptime) epoch=$(date +%s)"

fail() {
  echo "VBOARD-ERROR $*"
  poweroff -f
}
ip link add dev vcan0 type vcan || fail "ip link add vcan0 type vcan"
link_up vcan0 || fail "link_up vcan0"
sim=/sys/kernel/config/gpio-sim/vboard
mkdir "$sim" "$sim/bank0" || fail "gpio-sim configfs"
echo 32 > "$sim/bank0/num_lines"
echo vboard-bank0 > "$sim/bank0/label"
echo 1 > "$sim/live" || fail "gpio-sim live"
echo "VBOARD-GPIO chip=$(cat "$sim/bank0/chip_name") dev=$(cat "$sim/dev_name")"

candump -L vcan0 > /tmp/candump.log &
dump=$!
t0=$(cut -d' ' -f1 /proc/uptime)
mrd-hil run /vboard/scenario.toml --transport can --clock lockstep \
  --firmware /bin/mrd-firmware --can-interface vcan0 --gpio-sim "$sim" \
  --out /tmp/run --json > /tmp/result.json 2> /tmp/result.err
rc=$?
t1=$(cut -d' ' -f1 /proc/uptime)
sleep 1
kill "$dump"
echo "VBOARD-RUN rc=$rc start=$t0 end=$t1"
echo "===MRD-RESULT-BEGIN==="
cat /tmp/result.json
echo "===MRD-RESULT-END==="
echo "===MRD-CONFIG-BEGIN==="
cat /tmp/run/firmware.toml
echo "===MRD-CONFIG-END==="
echo "===MRD-STDERR-BEGIN==="
tail -n 40 /tmp/result.err
tail -n 20 /tmp/run/firmware.err 2>/dev/null
echo "===MRD-STDERR-END==="
echo "VBOARD-CANDUMP lines=$(wc -l < /tmp/candump.log)"
echo "===MRD-CANDUMP-BEGIN==="
gzip -c /tmp/candump.log | base64
echo "===MRD-CANDUMP-END==="
echo "VBOARD-CLOCK end uptime=$(cut -d' ' -f1 /proc/uptime) epoch=$(date +%s)"
poweroff -f
