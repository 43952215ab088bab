#!/usr/bin/env python3
"""Writes the MCAP fixtures of tests/integration/mcap.rs with an independent writer.

The files are ROS 2 bags in MCAP form as rosbag2 writes them (profile "ros2", message encoding
"cdr", schemas in the concatenated .msg text format "ros2msg"), made with foxglove's Python `mcap`
and `mcap-ros2-support` packages, which share no code with the Rust `mcap` crate imunoise reads
them with, and whose CDR encoder shares none with imunoise's hand-written decoder.

  imu_200hz.mcap   /imu/data         sensor_msgs/msg/Imu          200 Hz, 4000 messages (20 s)
                   /imu/temperature  sensor_msgs/msg/Temperature  1 Hz, 20 messages
                   zstd chunks of at most 32 KiB, so the reader crosses many chunk boundaries.
  two_imus.mcap    /imu0/data        sensor_msgs/msg/Imu          100 Hz, 200 messages
                   /imu1/data        sensor_msgs/msg/Imu          100 Hz, 200 messages, no gyro
                                     (angular_velocity_covariance[0] = -1, the ROS convention)
                   /chatter          std_msgs/msg/String          10 messages
                   lz4 chunks.
  no_imu.mcap      /chatter          std_msgs/msg/String          uncompressed chunks.
  bad_message.mcap /imu/data         sensor_msgs/msg/Imu          100 Hz, 60 messages, of which
                                     message 50 is cut to 100 bytes (written raw, uncompressed)
  imu_ros1.mcap    /imu/data         sensor_msgs/Imu (ROS 1)      100 Hz, 300 messages
                   /imu/temperature  sensor_msgs/Temperature      1 Hz, 3 messages
                   ROS 1 messages in MCAP (profile "ros1", encoding "ros1"), as `mcap convert
                   IN.bag OUT.mcap` writes them, made with `mcap-ros1-support`.

Values are closed-form and exact in binary floating point, so the Rust test recomputes them and
compares bit for bit (keep `splitmix64`, `counts`, `stamp_ns` and the scales in step with
tests/integration/mcap.rs):

  counts(seed, k, c) = sum of the four 10-bit fields at bits 54, 44, 34, 24 of
                       splitmix64(seed * 2**32 + 8 * k + c), minus 2046   (integer in [-2046, 2046])
  gyro  axis c (0..2) = counts(seed, k, c)     * 2**-16                  rad/s
  accel axis c (0..2) = counts(seed, k, c + 3) * 2**-12 + ACCEL_OFFSET[c]  m/s^2
  header stamp of IMU message k = T0 + k * period + jitter(k),  jitter(k) = ((splitmix64(k) >> 60) - 8) us
  log time = header stamp + 2 ms + (k mod 7) * 0.1 ms (IMU), + 30 ms (temperature): log times
             give other intervals and another temperature hold, so the reader must use header stamps.
  temperature message j: header stamp T0 + 0.5 s + j s, value 25 + j / 8 degC, variance 0.01.

Regenerate (from the repository root; the output is byte-for-byte deterministic for a given version
of the writer packages, and the values do not depend on it):

  python3 -m venv /tmp/mcapvenv
  /tmp/mcapvenv/bin/pip install mcap==1.6.0 mcap-ros2-support==0.6.0 mcap-ros1-support==0.9.0 \
      zstandard lz4
  /tmp/mcapvenv/bin/python tests/data/mcap/make_mcap.py
"""
import pathlib

from mcap.well_known import SchemaEncoding
from mcap.writer import CompressionType
from mcap.writer import Writer as RawWriter
from mcap_ros1._vendor.genpy import dynamic as ros1_dynamic
from mcap_ros1.writer import Writer as Ros1Writer
from mcap_ros2._dynamic import serialize_dynamic
from mcap_ros2.writer import Writer

HERE = pathlib.Path(__file__).resolve().parent

MASK64 = (1 << 64) - 1
T0 = 1_700_000_000 * 10**9  # header stamp of the first IMU message, ns since the epoch
ACCEL_OFFSET = (0.125, -0.25, 9.8125)

# sensor_msgs/msg/Imu as rosbag2 stores it: the type's own .msg text, then each dependency after a
# separator line (comments trimmed).
IMU_MSGDEF = """\
# This is a message to hold data from an IMU (Inertial Measurement Unit)
std_msgs/Header header

geometry_msgs/Quaternion orientation
float64[9] orientation_covariance # Row major about x, y, z axes

geometry_msgs/Vector3 angular_velocity
float64[9] angular_velocity_covariance # Row major about x, y, z axes

geometry_msgs/Vector3 linear_acceleration
float64[9] linear_acceleration_covariance # Row major x, y z

================================================================================
MSG: std_msgs/Header
# Standard metadata for higher-level stamped data types.
builtin_interfaces/Time stamp
string frame_id

================================================================================
MSG: builtin_interfaces/Time
# This message communicates ROS Time defined here:
int32 sec
uint32 nanosec

================================================================================
MSG: geometry_msgs/Quaternion
# This represents an orientation in free space in quaternion form.
float64 x 0
float64 y 0
float64 z 0
float64 w 1

================================================================================
MSG: geometry_msgs/Vector3
# This represents a vector in free space.
float64 x
float64 y
float64 z
"""

TEMPERATURE_MSGDEF = """\
# Single temperature reading.
std_msgs/Header header # timestamp is the time the temperature was measured
float64 temperature # Measurement of the Temperature in Degrees Celsius.
float64 variance # 0 is interpreted as variance unknown

================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id

================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""

STRING_MSGDEF = "string data\n"

ROS1_HEADER = """\
================================================================================
MSG: std_msgs/Header
uint32 seq
time stamp
string frame_id
"""

ROS1_IMU_MSGDEF = """\
std_msgs/Header header
geometry_msgs/Quaternion orientation
float64[9] orientation_covariance
geometry_msgs/Vector3 angular_velocity
float64[9] angular_velocity_covariance
geometry_msgs/Vector3 linear_acceleration
float64[9] linear_acceleration_covariance
""" + ROS1_HEADER + """\
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
"""

ROS1_TEMPERATURE_MSGDEF = """\
std_msgs/Header header
float64 temperature
float64 variance
""" + ROS1_HEADER


def splitmix64(x):
    z = (x + 0x9E3779B97F4A7C15) & MASK64
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
    return z ^ (z >> 31)


def counts(seed, k, c):
    z = splitmix64(((seed << 32) + 8 * k + c) & MASK64)
    return sum((z >> shift) & 0x3FF for shift in (54, 44, 34, 24)) - 2046


def stamp_ns(k, period_ns):
    return T0 + k * period_ns + ((splitmix64(k) >> 60) - 8) * 1000


def imu_log_time(ns, k):
    """When the recorder logged IMU message k stamped `ns`: a varying latency."""
    return ns + 2_000_000 + (k % 7) * 100_000


def header(ns, frame_id):
    return {"stamp": {"sec": ns // 10**9, "nanosec": ns % 10**9}, "frame_id": frame_id}


def imu_message(seed, k, period_ns, frame_id, gyro=True):
    ns = stamp_ns(k, period_ns)
    g = [counts(seed, k, c) * 2.0**-16 for c in range(3)] if gyro else [0.0, 0.0, 0.0]
    a = [counts(seed, k, c + 3) * 2.0**-12 + ACCEL_OFFSET[c] for c in range(3)]
    no_estimate = [-1.0] + [0.0] * 8
    diagonal = [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4]
    return ns, {
        "header": header(ns, frame_id),
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        "orientation_covariance": no_estimate,
        "angular_velocity": dict(zip("xyz", g)),
        "angular_velocity_covariance": diagonal if gyro else no_estimate,
        "linear_acceleration": dict(zip("xyz", a)),
        "linear_acceleration_covariance": diagonal,
    }


def write(name, compression, chunk_size, messages, schemas):
    """`messages`: (log_time_ns, topic, type_name, message); written in log-time order."""
    path = HERE / name
    with open(path, "wb") as f:
        writer = Writer(f, chunk_size=chunk_size, compression=compression)
        registered = {t: writer.register_msgdef(t, text) for t, text in schemas.items()}
        for log_time, topic, type_name, message in sorted(messages, key=lambda m: m[0]):
            writer.write_message(
                topic, registered[type_name], message, log_time=log_time, publish_time=log_time
            )
        writer.finish()
    print(f"wrote {path} ({path.stat().st_size} bytes, {len(messages)} messages)")


def main():
    imu, temp, string = "sensor_msgs/msg/Imu", "sensor_msgs/msg/Temperature", "std_msgs/msg/String"
    all_schemas = {imu: IMU_MSGDEF, temp: TEMPERATURE_MSGDEF, string: STRING_MSGDEF}

    messages = []
    for k in range(4000):
        ns, m = imu_message(1, k, 5_000_000, "imu_link")
        messages.append((imu_log_time(ns, k), "/imu/data", imu, m))
    for j in range(20):
        ns = T0 + 500_000_000 + j * 10**9
        m = {"header": header(ns, "imu_link"), "temperature": 25.0 + j / 8, "variance": 0.01}
        messages.append((ns + 30_000_000, "/imu/temperature", temp, m))
    write("imu_200hz.mcap", CompressionType.ZSTD, 32 * 1024, messages,
          {imu: IMU_MSGDEF, temp: TEMPERATURE_MSGDEF})

    messages = []
    for k in range(200):
        ns, m = imu_message(2, k, 10_000_000, "imu0")
        messages.append((imu_log_time(ns, k), "/imu0/data", imu, m))
        ns, m = imu_message(3, k, 10_000_000, "imu1", gyro=False)
        messages.append((imu_log_time(ns, k), "/imu1/data", imu, m))
    for j in range(10):
        messages.append((T0 + j * 200_000_000, "/chatter", string, {"data": f"hello {j}"}))
    write("two_imus.mcap", CompressionType.LZ4, 16 * 1024, messages, all_schemas)

    messages = [(T0 + j * 10**8, "/chatter", string, {"data": f"hello {j}"}) for j in range(5)]
    write("no_imu.mcap", CompressionType.NONE, 1024 * 1024, messages, {string: STRING_MSGDEF})

    write_bad_message()
    write_ros1()


def write_bad_message():
    """An IMU topic whose message 50 is cut short: the reader must fail there, naming it."""
    encode = serialize_dynamic("sensor_msgs/msg/Imu", IMU_MSGDEF)["sensor_msgs/msg/Imu"]
    path = HERE / "bad_message.mcap"
    with open(path, "wb") as f:
        writer = RawWriter(f, compression=CompressionType.NONE)
        writer.start(profile="ros2", library="make_mcap.py")
        schema = writer.register_schema(
            "sensor_msgs/msg/Imu", SchemaEncoding.ROS2, IMU_MSGDEF.encode()
        )
        channel = writer.register_channel("/imu/data", "cdr", schema)
        for k in range(60):
            ns, m = imu_message(5, k, 10_000_000, "imu_link")
            data = encode(m)
            if k == 50:
                data = data[:100]
            writer.add_message(channel, log_time=imu_log_time(ns, k), data=data,
                               publish_time=imu_log_time(ns, k), sequence=k)
        writer.finish()
    print(f"wrote {path} ({path.stat().st_size} bytes, 60 messages)")


def write_ros1():
    """ROS 1 messages in MCAP, as `mcap convert` makes from a ROS 1 bag."""
    imu_cls = ros1_dynamic.generate_dynamic("sensor_msgs/Imu", ROS1_IMU_MSGDEF)["sensor_msgs/Imu"]
    temp_cls = ros1_dynamic.generate_dynamic("sensor_msgs/Temperature", ROS1_TEMPERATURE_MSGDEF)[
        "sensor_msgs/Temperature"
    ]

    def fill_header(m, seq, ns):
        m.header.seq = seq
        m.header.stamp.secs, m.header.stamp.nsecs = divmod(ns, 10**9)
        m.header.frame_id = "imu_link"

    messages = []
    for k in range(300):
        ns, fields = imu_message(4, k, 10_000_000, "imu_link")
        m = imu_cls()
        fill_header(m, k, ns)
        for name in ("angular_velocity", "linear_acceleration"):
            for axis in "xyz":
                setattr(getattr(m, name), axis, fields[name][axis])
        m.orientation.w = 1.0
        m.orientation_covariance = fields["orientation_covariance"]
        m.angular_velocity_covariance = fields["angular_velocity_covariance"]
        m.linear_acceleration_covariance = fields["linear_acceleration_covariance"]
        messages.append((imu_log_time(ns, k), "/imu/data", m))
    for j in range(3):
        ns = T0 + 500_000_000 + j * 10**9
        m = temp_cls()
        fill_header(m, j, ns)
        m.temperature, m.variance = 25.0 + j / 8, 0.01
        messages.append((ns + 30_000_000, "/imu/temperature", m))
    path = HERE / "imu_ros1.mcap"
    with open(path, "wb") as f:
        writer = Ros1Writer(f, chunk_size=64 * 1024, compression=CompressionType.ZSTD)
        for log_time, topic, m in sorted(messages, key=lambda m: m[0]):
            writer.write_message(topic, m, log_time=log_time, publish_time=log_time)
        writer.finish()
    print(f"wrote {path} ({path.stat().st_size} bytes, {len(messages)} messages)")


if __name__ == "__main__":
    main()
