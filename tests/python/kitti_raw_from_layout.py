"""Writes one sequence of a KITTI tracking layout as a KITTI raw drive, the layout that pykitti
and kitti2mcap read, so that a converter made for raw drives can be run on the committed
fixture:

    python kitti_raw_from_layout.py TRACKING_DIR SEQUENCE RAW_DIR DATE DRIVE

    RAW_DIR/DATE/calib_cam_to_cam.txt, calib_velo_to_cam.txt, calib_imu_to_velo.txt
    RAW_DIR/DATE/DATE_drive_DRIVE_sync/image_02/data/NNNNNNNNNN.png   (and image_03)
    RAW_DIR/DATE/DATE_drive_DRIVE_sync/image_02/timestamps.txt        (and image_03)
    RAW_DIR/DATE/DATE_drive_DRIVE_sync/velodyne_points/timestamps.txt, data/NNNNNNNNNN.bin
    RAW_DIR/DATE/DATE_drive_DRIVE_sync/oxts/timestamps.txt

Images are copied byte for byte. The projections P0..P3 become P_rect_00..P_rect_03 with the
tracking file's one rectifying rotation for every camera; the rest of each camera's entries
(S, K, D, R, T) are what a rectified, undistorted camera has, which the rendered fixture is.
Every sensor is stamped at 10 Hz from DATE 13:00:00 UTC, the stereo pair at the same instants.
Exits non-zero, with the reason, on a missing image or calibration key.
"""

import shutil
import struct
import sys
from datetime import datetime, timezone
from pathlib import Path

# The drive's clock: KITTI raw records at 10 Hz; its timestamps.txt lines carry nanoseconds.
PERIOD_NS = 100_000_000
CALIB_TIME = "calib_time: 01-Jan-2011 00:00:00"

# Both spellings of the tracking calibration's keys (the devkit's and the object benchmark's).
SPELLINGS = {
    "R_rect": "R0_rect",
    "Tr_velo_cam": "Tr_velo_to_cam",
    "Tr_imu_velo": "Tr_imu_to_velo",
}


def numbers(values) -> str:
    # repr keeps every digit: the bag's CameraInfo must carry the very projection of the fixture.
    return " ".join(repr(float(v)) for v in values)


def read_tracking_calib(path: Path) -> dict:
    calib = {}
    for line in path.read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        key = parts[0].rstrip(":")
        calib[SPELLINGS.get(key, key)] = [float(v) for v in parts[1:]]
    for key, count in [("P0", 12), ("P1", 12), ("P2", 12), ("P3", 12), ("R0_rect", 9),
                       ("Tr_velo_to_cam", 12), ("Tr_imu_to_velo", 12)]:
        if len(calib.get(key, [])) != count:
            raise SystemExit(f"{path}: key {key}: expected {count} numbers, found {calib.get(key)}")
    return calib


def png_size(path: Path) -> tuple[int, int]:
    # A PNG's IHDR chunk, which opens every PNG after the signature, holds width and height.
    head = path.read_bytes()[:24]
    if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        raise SystemExit(f"{path}: not a PNG")
    return struct.unpack(">II", head[16:24])


def offset(p: list) -> list:
    """The camera's position in the rectified reference frame, metres: K^-1 times P's last
    column, K being P's left 3 x 3 block (upper triangular)."""
    (fx, s, cx, a), (_, fy, cy, b), (_, _, one, c) = p[0:4], p[4:8], p[8:12]
    z = c / one
    y = (b - cy * z) / fy
    x = (a - s * y - cx * z) / fx
    return [x, y, z]


def cam_to_cam(calib: dict, size: tuple[int, int]) -> str:
    lines = [CALIB_TIME, "corner_dist: 0.0"]
    for cam in range(4):
        p = calib[f"P{cam}"]
        k = p[0:3] + p[4:7] + p[8:11]
        lines += [
            f"S_0{cam}: {numbers(size)}",
            f"K_0{cam}: {numbers(k)}",
            f"D_0{cam}: {numbers([0.0] * 5)}",
            f"R_0{cam}: {numbers([1, 0, 0, 0, 1, 0, 0, 0, 1])}",
            f"T_0{cam}: {numbers(offset(p))}",
            f"S_rect_0{cam}: {numbers(size)}",
            f"R_rect_0{cam}: {numbers(calib['R0_rect'])}",
            f"P_rect_0{cam}: {numbers(p)}",
        ]
    return "\n".join(lines) + "\n"


def rigid(m: list, extra: list[str]) -> str:
    """A 3 x 4 row-major transform as KITTI raw's `R:` and `T:` lines."""
    r = m[0:3] + m[4:7] + m[8:11]
    t = [m[3], m[7], m[11]]
    return "\n".join([CALIB_TIME, f"R: {numbers(r)}", f"T: {numbers(t)}", *extra]) + "\n"


def stamp(start_ns: int, k: int) -> str:
    ns = start_ns + k * PERIOD_NS
    seconds, nanos = divmod(ns, 1_000_000_000)
    when = datetime.fromtimestamp(seconds, tz=timezone.utc).strftime("%Y-%m-%d %H:%M:%S")
    return f"{when}.{nanos:09d}"


def main(tracking: Path, seq: str, raw: Path, date: str, drive: str) -> None:
    calib = read_tracking_calib(tracking / "calib" / f"{seq}.txt")
    lefts = sorted((tracking / "image_02" / seq).glob("*.png"))
    rights = sorted((tracking / "image_03" / seq).glob("*.png"))
    if not lefts or [p.name for p in lefts] != [p.name for p in rights]:
        raise SystemExit(f"{tracking}: image_02/{seq} and image_03/{seq} do not hold the same frames")
    day = raw / date
    drive_dir = day / f"{date}_drive_{drive}_sync"
    start = datetime.strptime(date, "%Y_%m_%d").replace(hour=13, tzinfo=timezone.utc)
    start_ns = int(start.timestamp()) * 1_000_000_000
    # pykitti parses each line up to its last 4 characters, so every line ends with a newline.
    stamps = "".join(stamp(start_ns, k) + "\n" for k in range(len(lefts)))
    for folder, images in [("image_02", lefts), ("image_03", rights)]:
        (drive_dir / folder / "data").mkdir(parents=True)
        for k, image in enumerate(images):
            shutil.copyfile(image, drive_dir / folder / "data" / f"{k:010d}.png")
        (drive_dir / folder / "timestamps.txt").write_text(stamps)
    # kitti2mcap counts the drive's frames in velodyne_points/data and stamps /tf_static with the
    # first velodyne stamp, even with --no-lidar; the scans are never read then, so they are
    # empty (no points).
    (drive_dir / "velodyne_points" / "data").mkdir(parents=True)
    for k in range(len(lefts)):
        (drive_dir / "velodyne_points" / "data" / f"{k:010d}.bin").write_bytes(b"")
    (drive_dir / "velodyne_points" / "timestamps.txt").write_text(stamps)
    # pykitti reads the OXTS stamps whatever is converted; with --no-imu no packet is read.
    (drive_dir / "oxts").mkdir()
    (drive_dir / "oxts" / "timestamps.txt").write_text(stamps)
    (day / "calib_cam_to_cam.txt").write_text(cam_to_cam(calib, png_size(lefts[0])))
    (day / "calib_velo_to_cam.txt").write_text(
        rigid(calib["Tr_velo_to_cam"], ["delta_f: 0.0 0.0", "delta_c: 0.0 0.0"]))
    (day / "calib_imu_to_velo.txt").write_text(rigid(calib["Tr_imu_to_velo"], []))
    print(f"wrote {len(lefts)} frames of sequence {seq} as drive {date}_drive_{drive}_sync to {raw}")


if __name__ == "__main__":
    if len(sys.argv) != 6:
        raise SystemExit(__doc__)
    main(Path(sys.argv[1]), sys.argv[2], Path(sys.argv[3]), sys.argv[4], sys.argv[5])
