"""Image payloads of a recording: format sniffing, header sizes, raw pixels, decoding to BGR."""

from __future__ import annotations

import hashlib
import re
import struct
from collections.abc import Collection
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from superlane_tools.recording.streams import RAW_IMAGE_TYPES
from superlane_tools.recording.video import DECODED_MSGTYPE, decoded_image
from superlane_tools.records import Message

_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
_SAFE_TOPIC = re.compile(r"[^A-Za-z0-9_.-]+")

# ROS / Foxglove raw encodings -> (channels, numpy dtype, cv2 conversion to BGR or None)
RAW_ENCODINGS: dict[str, tuple[int, str, str | None]] = {
    "mono8": (1, "u1", None),
    "8UC1": (1, "u1", None),
    "mono16": (1, "u2", None),
    "16UC1": (1, "u2", None),
    "bgr8": (3, "u1", None),
    "8UC3": (3, "u1", None),
    "rgb8": (3, "u1", "COLOR_RGB2BGR"),
    "bgra8": (4, "u1", None),
    "rgba8": (4, "u1", "COLOR_RGBA2BGRA"),
}


class ImageSize(NamedTuple):
    """Image size in pixels."""

    width: int
    height: int


def sniff_format(payload: bytes) -> str | None:
    """Return ``jpeg`` or ``png`` from the payload's magic bytes, else None."""
    if payload.startswith(b"\xff\xd8\xff"):
        return "jpeg"
    if payload.startswith(_PNG_MAGIC):
        return "png"
    return None


def jpeg_size(payload: bytes) -> ImageSize | None:
    """Read width and height from a JPEG's SOF segment without decoding; None if malformed.

    A payload without the end-of-image marker (a truncated transfer) also gives None.
    """
    if not payload.startswith(b"\xff\xd8") or payload.rstrip(b"\0")[-2:] != b"\xff\xd9":
        return None
    pos, end = 2, len(payload)
    while pos + 4 <= end:
        if payload[pos] != 0xFF:
            return None
        marker = payload[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        if marker in (0x01, *range(0xD0, 0xD8)):  # standalone markers
            pos += 2
            continue
        (length,) = struct.unpack_from(">H", payload, pos + 2)
        if marker in _JPEG_SOF:
            if pos + 9 > end:
                return None
            height, width = struct.unpack_from(">HH", payload, pos + 5)
            return ImageSize(width, height) if width and height else None
        if marker == 0xDA or length < 2:  # scan data before any SOF: malformed
            return None
        pos += 2 + length
    return None


def png_size(payload: bytes) -> ImageSize | None:
    """Read width and height from a PNG's IHDR chunk; None if malformed."""
    if len(payload) < 24 or not payload.startswith(_PNG_MAGIC) or payload[12:16] != b"IHDR":
        return None
    width, height = struct.unpack_from(">II", payload, 16)
    return ImageSize(width, height) if width and height else None


def header_size(payload: bytes, fmt: str) -> ImageSize | None:
    """Return the size stored in a ``jpeg`` or ``png`` header, else None."""
    if fmt == "jpeg":
        return jpeg_size(payload)
    if fmt == "png":
        return png_size(payload)
    return None


MIN_FRAME_SIDE = 8
"""Smallest image side (pixels) a frame is processed at; smaller frames are skipped."""
MAX_IMAGE_PIXELS = 1 << 28
"""Largest image (width x height) decoded; a bigger header is damage (cv2 refuses 2^30)."""


def imdecode(payload: bytes, flags: int) -> Any:
    """Decode a compressed image with cv2; never raise anything but ValueError.

    A header claiming more than :data:`MAX_IMAGE_PIXELS` is refused before decoding (cv2
    would try to allocate it, or raise ``cv2.error``).

    Raises:
        ValueError: If the payload is empty, claims an absurd size, or cannot be decoded.
    """
    import cv2

    if not payload:
        raise ValueError("empty image payload")
    fmt = sniff_format(payload)
    size = header_size(payload, fmt) if fmt else None
    if size is not None and size.width * size.height > MAX_IMAGE_PIXELS:
        raise ValueError(f"image header claims {size.width}x{size.height} pixels")
    try:
        pixels = cv2.imdecode(np.frombuffer(payload, dtype=np.uint8), flags)
    except cv2.error as err:
        raise ValueError(f"image payload cannot be decoded: {str(err).strip()[:80]}") from err
    if pixels is None or pixels.size == 0:
        raise ValueError("image payload cannot be decoded")
    return pixels


def raw_pixels(data: Any, width: int, height: int, encoding: str, step: int) -> npt.NDArray[Any]:
    """Turn a raw image message's buffer into an array cv2 can encode (BGR order).

    Raises:
        ValueError: For an unsupported encoding or a buffer too small for the size.
    """
    import cv2

    if encoding not in RAW_ENCODINGS:
        raise ValueError(f"unsupported raw image encoding {encoding!r}")
    channels, dtype, conversion = RAW_ENCODINGS[encoding]
    itemsize = np.dtype(dtype).itemsize
    buffer = np.frombuffer(bytes(data), dtype=np.uint8)
    row_bytes = width * channels * itemsize
    step = step or row_bytes
    if (
        width <= 0
        or height <= 0
        or step < row_bytes
        or buffer.size < step * (height - 1) + row_bytes
    ):
        raise ValueError(f"raw image buffer of {buffer.size} bytes does not hold {width}x{height}")
    padded = np.pad(buffer, (0, max(0, step * height - buffer.size)))
    rows = padded[: step * height].reshape(height, step)[:, :row_bytes]
    pixels = np.ascontiguousarray(rows).view(dtype)
    pixels = (
        pixels.reshape(height, width, channels) if channels > 1 else pixels.reshape(height, width)
    )
    if conversion is not None:
        pixels = cv2.cvtColor(pixels, getattr(cv2, conversion))
    return pixels


MAX_FOLDER_NAME = 100
"""Longest folder name made from a topic (file systems allow 255 bytes)."""


def safe_topic(topic: str, taken: Collection[str] = ()) -> str:
    """Return a topic name usable as one folder name (``/cam/front`` -> ``cam_front``).

    Names longer than :data:`MAX_FOLDER_NAME`, and names already in ``taken`` (topics such as
    ``/cam/front`` and ``/cam_front``, or ``/cam/ä`` and ``/cam/ö``, sanitise alike), get a
    short hash of the full topic name appended, so two topics never share a folder.
    """
    name = _SAFE_TOPIC.sub("_", topic.strip("/")).strip("._") or "_"
    if len(name) > MAX_FOLDER_NAME or name in taken:
        digest = hashlib.sha1(topic.encode("utf-8", "surrogatepass")).hexdigest()[:10]
        name = f"{name[: MAX_FOLDER_NAME - 11]}-{digest}"
    return name


def decode_frame(msg: Message) -> NDArray[np.uint8]:
    """Decode an image message into a BGR uint8 array.

    Raises:
        ValueError: If the payload is corrupt or the encoding unsupported.
    """
    import cv2

    data = msg.data
    if msg.msgtype == DECODED_MSGTYPE:  # video, decoded in order by recording.video
        return decoded_image(msg)
    if msg.msgtype in RAW_IMAGE_TYPES:
        pixels = raw_pixels(
            data.data,
            int(data.width),
            int(data.height),
            str(data.encoding),
            int(getattr(data, "step", 0) or 0),
        )
    else:
        pixels = imdecode(bytes(data.data), cv2.IMREAD_UNCHANGED)
    if pixels.dtype != np.uint8:
        pixels = (
            (pixels >> 8).astype(np.uint8) if pixels.dtype == np.uint16 else pixels.astype(np.uint8)
        )
    if min(pixels.shape[:2]) < MIN_FRAME_SIDE:
        raise ValueError(f"image {pixels.shape[1]}x{pixels.shape[0]} too small to process")
    if pixels.ndim == 2:
        pixels = cv2.cvtColor(pixels, cv2.COLOR_GRAY2BGR)
    elif pixels.shape[2] == 4:
        pixels = cv2.cvtColor(pixels, cv2.COLOR_BGRA2BGR)
    out: NDArray[np.uint8] = np.ascontiguousarray(pixels)
    return out


#: JPEG decoding with DCT-domain downscaling (libjpeg scales by 1/2, 1/4, 1/8 while decoding).
_REDUCED_FLAGS = (
    (8, "IMREAD_REDUCED_COLOR_8"),
    (4, "IMREAD_REDUCED_COLOR_4"),
    (2, "IMREAD_REDUCED_COLOR_2"),
)


def decode_reduced(
    msg: Message, target_width: int
) -> tuple[NDArray[np.uint8], tuple[int, int]] | None:
    """Decode a JPEG frame directly at a reduced size, if one still covers ``target_width``.

    libjpeg skips most of the inverse DCT when it scales by 1/2, 1/4 or 1/8, so decoding a
    1280x720 frame at 640x360 costs about a third of a full decode plus resize.

    Args:
        msg: A compressed image message.
        target_width: Width the frame will be processed at, pixels (<= 0: full size).

    Returns:
        The BGR image at the largest reduction whose width is still >= ``target_width``, and the
        recorded ``(width, height)``; None when the frame is not a JPEG, is not reducible for
        this target, or cannot be decoded this way (decode it with :func:`decode_frame`).
    """
    if target_width <= 0 or msg.msgtype in RAW_IMAGE_TYPES or msg.msgtype == DECODED_MSGTYPE:
        return None
    payload = bytes(msg.data.data)
    if sniff_format(payload) != "jpeg":
        return None
    size = jpeg_size(payload)
    if size is None:
        return None
    import cv2

    for factor, flag in _REDUCED_FLAGS:
        if -(-size.width // factor) >= target_width:
            try:
                decoded = imdecode(payload, getattr(cv2, flag))
            except ValueError:
                return None  # decode_frame reports it
            if decoded.ndim != 3 or decoded.dtype != np.uint8:
                return None
            if min(decoded.shape[:2]) < MIN_FRAME_SIDE:
                return None
            return np.ascontiguousarray(decoded), (size.width, size.height)
    return None
