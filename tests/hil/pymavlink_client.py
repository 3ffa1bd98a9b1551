"""A MAVLink client that knows nothing of heli: pymavlink, common dialect, MAVLink 2, signed.

Usage: pymavlink_client.py PORT KEYFILE LOGFILE
Connects to the vehicle on udp 127.0.0.1:PORT, reads heartbeats and telemetry at the rates
set, changes a message interval, lists and downloads a log (compared with LOGFILE), and
sends Connect, Start Logging and a signed Stop, and fetches the flight's plan over the mission
protocol. Prints ALL OK at the end.
"""
import os
import sys
import time

os.environ["MAVLINK20"] = "1"
os.environ["MAVLINK_DIALECT"] = "common"
from pymavlink import mavutil  # noqa: E402

port, keyfile, logfile = int(sys.argv[1]), sys.argv[2], sys.argv[3]
key_hex = "".join(l.strip() for l in open(keyfile) if l.strip() and not l.startswith("#"))
key = bytes.fromhex(key_hex)

m = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255,
                               source_component=190, dialect="common")
m.setup_signing(key, sign_outgoing=True)
mav = m.mav
C = mavutil.mavlink


def beat():
    mav.heartbeat_send(C.MAV_TYPE_GCS, C.MAV_AUTOPILOT_INVALID, 0, 0, C.MAV_STATE_ACTIVE)


def pump(seconds, want=None):
    """Receives for `seconds`, beating; returns counts by type (and the first `want`)."""
    counts, found = {}, None
    end, last = time.time() + seconds, 0.0
    while time.time() < end:
        if time.time() - last > 0.5:
            beat()
            last = time.time()
        msg = m.recv_match(blocking=True, timeout=0.05)
        if msg is None:
            continue
        t = msg.get_type()
        counts[t] = counts.get(t, 0) + 1
        if want and found is None and want(msg):
            found = msg
            return counts, found
    return counts, found


def command(cmd, *params, timeout=20):
    p = list(params) + [0.0] * (7 - len(params))
    deadline = time.time() + timeout
    mav.command_long_send(1, 1, cmd, 0, *p)
    while time.time() < deadline:
        _, ack = pump(0.5, lambda x: x.get_type() == "COMMAND_ACK" and x.command == cmd
                      and x.result != C.MAV_RESULT_IN_PROGRESS)
        if ack is not None:
            return ack.result
    raise SystemExit(f"no final COMMAND_ACK for {cmd}")


def pack(text):
    b = text.encode() + bytes(15 - len(text))
    return [float(b[i] | b[i + 1] << 8 | b[i + 2] << 16) for i in range(0, 15, 3)]


beat()
hb = m.wait_heartbeat(timeout=10)
assert hb is not None, "no heartbeat"
assert hb.type == C.MAV_TYPE_HELICOPTER, hb
assert m.mav.signing.goodsig_count > 0, "the vehicle's frames are signed"
print("heartbeat ok: helicopter, signed")

# Who it is, as QGroundControl asks at connection.
assert command(C.MAV_CMD_REQUEST_MESSAGE, float(C.MAVLINK_MSG_ID_AUTOPILOT_VERSION)) \
    == C.MAV_RESULT_ACCEPTED
_, v = pump(5.0, lambda x: x.get_type() == "AUTOPILOT_VERSION")
assert v is not None, "no AUTOPILOT_VERSION"
assert v.capabilities & C.MAV_PROTOCOL_CAPABILITY_MAVLINK2, v
print(f"autopilot version ok: {v.flight_sw_version >> 24}.{(v.flight_sw_version >> 16) & 0xff}")

mav.param_request_read_send(1, 1, b"YAW_RATE_P", -1)
_, p = pump(5.0, lambda x: x.get_type() == "PARAM_VALUE" and x.param_id == "YAW_RATE_P")
assert p is not None and abs(p.param_value - 0.3) < 1e-6, p
mav.param_set_send(1, 1, b"YAW_RATE_P", 0.25, C.MAV_PARAM_TYPE_REAL32)
_, p = pump(5.0, lambda x: x.get_type() == "PARAM_VALUE" and x.param_id == "YAW_RATE_P")
assert p is not None and abs(p.param_value - 0.25) < 1e-6, p
mav.param_set_send(1, 1, b"YAW_RATE_P", 9.0, C.MAV_PARAM_TYPE_REAL32)
counts, p = pump(5.0, lambda x: x.get_type() == "PARAM_VALUE" and x.param_id == "YAW_RATE_P")
assert p is not None and abs(p.param_value - 0.25) < 1e-6, f"a bad value changed it: {p}"
print("parameters ok: read, set, a bad value refused")

assert command(C.MAV_CMD_USER_1) == C.MAV_RESULT_ACCEPTED  # Connect
assert command(C.MAV_CMD_USER_2, 1.0, 1.0, *pack("py1")) == C.MAV_RESULT_ACCEPTED  # Start
print("connect and start logging ok")

counts, _ = pump(3.0)
imu = counts.get("SCALED_IMU", 0)
assert 6 <= imu <= 12, f"3 Hz for 3 s: {imu} SCALED_IMU ({counts})"
for name in ["HEARTBEAT", "SYS_STATUS", "RC_CHANNELS", "SERVO_OUTPUT_RAW", "GPS_RAW_INT",
             "SCALED_PRESSURE", "BATTERY_STATUS"]:
    assert counts.get(name, 0) > 0, f"no {name}: {counts}"
print(f"telemetry ok at 3 Hz: {counts}")

assert command(C.MAV_CMD_SET_MESSAGE_INTERVAL, float(C.MAVLINK_MSG_ID_SCALED_IMU), 100000.0) \
    == C.MAV_RESULT_ACCEPTED
counts, _ = pump(3.0)
imu = counts.get("SCALED_IMU", 0)
assert 24 <= imu <= 36, f"10 Hz for 3 s: {imu} SCALED_IMU"
print(f"interval ok: {imu} SCALED_IMU in 3 s")

# The flight's plan (hover: take off to 10 m, hold 60 s) over the mission protocol.
mav.mission_request_list_send(1, 1)
_, count = pump(5.0, lambda x: x.get_type() == "MISSION_COUNT")
assert count is not None and count.count == 2, count
items = []
for seq in range(count.count):
    mav.mission_request_int_send(1, 1, seq)
    _, item = pump(5.0, lambda x: x.get_type() == "MISSION_ITEM_INT" and x.seq == seq)
    assert item is not None, f"no mission item {seq}"
    items.append(item)
mav.mission_ack_send(1, 1, C.MAV_MISSION_ACCEPTED)
assert items[0].command == C.MAV_CMD_NAV_TAKEOFF_LOCAL and abs(items[0].z + 10.0) < 1e-6, items[0]
assert items[1].command == C.MAV_CMD_NAV_LOITER_TIME and items[1].param1 == 60.0, items[1]
assert all(i.frame == C.MAV_FRAME_LOCAL_NED for i in items)
print("mission ok: the hover's plan, 2 items")

mav.log_request_list_send(1, 1, 0, 0xFFFF)
_, entry = pump(5.0, lambda x: x.get_type() == "LOG_ENTRY" and x.id == 1)
assert entry is not None, "no LOG_ENTRY"
expected = open(logfile, "rb").read()
assert entry.size == len(expected), (entry.size, len(expected))
data = bytearray(entry.size)
have = set()
mav.log_request_data_send(1, 1, 1, 0, entry.size)
deadline = time.time() + 20
while len(have) * 90 < entry.size and time.time() < deadline:
    msg = m.recv_match(type="LOG_DATA", blocking=True, timeout=0.5)
    if msg is None:
        missing = min(set(range(0, entry.size, 90)) - have)
        mav.log_request_data_send(1, 1, 1, missing, entry.size - missing)
        continue
    if msg.count:
        data[msg.ofs:msg.ofs + msg.count] = bytes(msg.data[:msg.count])
        have.add(msg.ofs)
mav.log_request_end_send(1, 1)
assert bytes(data) == expected, "downloaded log differs"
print(f"log download ok: {entry.size} bytes")

assert command(C.MAV_CMD_USER_3) == C.MAV_RESULT_ACCEPTED  # a signed Stop
print("signed stop ok")
print("ALL OK")
