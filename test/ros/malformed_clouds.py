"""The malformed PointCloud2 corpus, made in code: every way a cloud from the outside has broken the node
(SIGSEGV, SIGABRT) or could, each with the reason the node must give for refusing it. Shared by the
malformed-cloud rostest (test_malformed_clouds.py) and the stress script (scripts/stress_registration.py).

Also a small reader of the shipped .pcd scans (x y z float32; ascii, binary or binary_compressed), so the
tests can send a real pair without PCL in Python."""
import struct

from sensor_msgs.msg import PointCloud2, PointField

FLOAT32 = PointField.FLOAT32


def xyz_cloud(points, frame, big_endian=False, point_step=16):
    """An unorganized cloud with float32 x, y, z at offsets 0, 4, 8 (PCL's padded layout by default)."""
    msg = PointCloud2()
    msg.header.frame_id = frame
    msg.height, msg.width = 1, len(points)
    msg.fields = [PointField(name, 4 * i, FLOAT32, 1) for i, name in enumerate("xyz")]
    msg.is_bigendian = big_endian
    msg.point_step = point_step
    msg.row_step = point_step * len(points)
    msg.is_dense = False
    order = ">" if big_endian else "<"
    padding = b"\0" * (point_step - 12)
    msg.data = b"".join(struct.pack(order + "3f", *p) + padding for p in points)
    return msg


def _field(msg, name):
    return next(f for f in msg.fields if f.name == name)


def _tetrahedron():
    return [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.5, 0.5, 0.5)]


def _with_offset(axis, offset):
    def build(frame):
        msg = xyz_cloud(_tetrahedron(), frame)
        _field(msg, axis).offset = offset
        return msg

    return build


def _float64_x(frame):
    msg = xyz_cloud(_tetrahedron(), frame)
    _field(msg, "x").datatype = PointField.FLOAT64
    return msg


def _duplicate_x(frame):
    msg = xyz_cloud(_tetrahedron(), frame)
    msg.fields.append(PointField("x", 12, FLOAT32, 1))
    return msg


def _missing_z(frame):
    msg = xyz_cloud(_tetrahedron(), frame)
    msg.fields = [f for f in msg.fields if f.name != "z"]
    return msg


def _overlapping(frame):
    msg = xyz_cloud(_tetrahedron(), frame)
    _field(msg, "y").offset = 2
    return msg


def _point_step_zero(frame):
    msg = xyz_cloud(_tetrahedron(), frame)
    msg.point_step = 0
    return msg


def _row_step_short(frame):
    msg = xyz_cloud(_tetrahedron(), frame)
    msg.row_step = msg.point_step * msg.width - 1
    return msg


def _truncated(frame):
    msg = xyz_cloud(_tetrahedron(), frame)
    msg.data = msg.data[: len(msg.data) // 2]
    return msg


def _grid_overflow(frame):
    # width x height = 2^32: 0 in 32-bit arithmetic, neither empty nor backed by data.
    msg = xyz_cloud(_tetrahedron(), frame)
    msg.width = msg.height = 1 << 16
    msg.row_step = msg.point_step * msg.width
    return msg


def _max_grid(frame):
    msg = xyz_cloud(_tetrahedron(), frame)
    msg.width = msg.height = msg.row_step = 0xFFFFFFFF
    return msg


def _far(value):
    return lambda frame: xyz_cloud(_tetrahedron()[:4] + [(value, 0.0, 0.0)], frame)


def _garbage_big_endian(frame):
    # 3e38 written big-endian and flagged so: decoded correctly, it is still beyond the bound.
    return xyz_cloud(_tetrahedron() + [(0.0, -3e38, 0.0)], frame, big_endian=True)


NAN = float("nan")

# (name, build(frame_id) -> PointCloud2, part of the reason the node must give)
CORPUS = [
    ("offset 0xFFFFFFFC on x", _with_offset("x", 0xFFFFFFFC), "field 'x' at offset 4294967292 lies outside"),
    ("offset 0xFFFFFFFD on y", _with_offset("y", 0xFFFFFFFD), "field 'y' at offset 4294967293 lies outside"),
    ("offset 0xFFFFFFFE on z", _with_offset("z", 0xFFFFFFFE), "field 'z' at offset 4294967294 lies outside"),
    ("offset 0xFFFFFFFF on x", _with_offset("x", 0xFFFFFFFF), "field 'x' at offset 4294967295 lies outside"),
    ("offset past point_step", _with_offset("z", 13), "field 'z' at offset 13 lies outside point_step 16"),
    ("x is float64", _float64_x, "field 'x' is not float32"),
    ("two x fields", _duplicate_x, "2 fields named 'x'"),
    ("no z field", _missing_z, "no 'z' field"),
    ("x and y overlap", _overlapping, "fields 'x' and 'y' overlap"),
    ("point_step 0", _point_step_zero, "point_step is 0"),
    ("row_step too small", _row_step_short, "row_step 79 is smaller than point_step x width = 80"),
    ("data truncated", _truncated, "data holds 40 bytes, fewer than row_step x height = 80"),
    ("width x height = 2^32", _grid_overflow, "fewer than row_step x height = 68719476736"),
    ("width = height = 2^32 - 1", _max_grid, "row_step 4294967295 is smaller than point_step x width"),
    ("x = 3e38", _far(3e38), "point 4 has x = 3e+38 m, beyond the front end's bound of +-1e+06 m"),
    ("x = 1e20", _far(1e20), "point 4 has x = 1e+20 m, beyond the front end's bound"),
    ("x = -2e6", _far(-2e6), "point 4 has x = -2e+06 m, beyond the front end's bound"),
    ("big-endian y = -3e38", _garbage_big_endian, "point 5 has y = -3e+38 m"),
    ("all NaN", lambda f: xyz_cloud([(NAN, NAN, NAN), (NAN, 0.0, 0.0), (0.0, NAN, 1.0)], f), "0 of its 3 points are finite"),
    ("one point", lambda f: xyz_cloud([(1.0, 2.0, 3.0)], f), "1 finite points"),
    ("two points", lambda f: xyz_cloud([(1.0, 2.0, 3.0), (2.0, 2.0, 3.0)], f), "2 finite points"),
    ("empty", lambda f: xyz_cloud([], f), "empty cloud"),
]


def has_points(msg):
    """Whether ~register takes `msg` as its target (an empty target means the latest one on `target`)."""
    return msg.width * msg.height > 0


# ---- the shipped scans


def _lzf_decompress(data, size):
    """LZF (liblzf's format, what PCL's binary_compressed uses): literal runs and back references."""
    out = bytearray()
    i = 0
    while i < len(data):
        control = data[i]
        i += 1
        if control < 32:  # a literal run of control + 1 bytes
            out += data[i : i + control + 1]
            i += control + 1
            continue
        length = control >> 5
        if length == 7:
            length += data[i]
            i += 1
        start = len(out) - ((control & 0x1F) << 8) - data[i] - 1
        i += 1
        for k in range(length + 2):  # may overlap what it writes: byte by byte
            out.append(out[start + k])
    if len(out) != size:
        raise ValueError("LZF data unpacks to %d bytes, not %d" % (len(out), size))
    return bytes(out)


def read_pcd_xyz(path):
    """The x y z of a .pcd whose fields are all float32 with count 1, as a list of (x, y, z)."""
    with open(path, "rb") as f:
        content = f.read()
    header, offset = {}, 0
    while "DATA" not in header:
        end = content.index(b"\n", offset)
        words = content[offset:end].decode("ascii").split()
        offset = end + 1
        if words and not words[0].startswith("#"):
            header[words[0]] = words[1:]
    fields = header["FIELDS"]
    if header["TYPE"] != ["F"] * len(fields) or header["SIZE"] != ["4"] * len(fields):
        raise ValueError("%s: only float32 fields are read here" % path)
    n = int(header["POINTS"][0])
    axes = [fields.index(a) for a in "xyz"]
    data = header["DATA"][0]
    if data == "ascii":
        rows = [line.split() for line in content[offset:].decode("ascii").splitlines() if line.strip()]
        return [tuple(float(row[a]) for a in axes) for row in rows[:n]]
    if data == "binary":
        values = struct.unpack_from("<%df" % (n * len(fields)), content, offset)
        return [tuple(values[p * len(fields) + a] for a in axes) for p in range(n)]
    compressed, size = struct.unpack_from("<II", content, offset)
    raw = _lzf_decompress(content[offset + 8 : offset + 8 + compressed], size)
    # binary_compressed stores each field's values together: all x, then all y, ...
    columns = [struct.unpack_from("<%df" % n, raw, 4 * n * a) for a in axes]
    return list(zip(*columns))
