"""Vectorised CAN signal decoding: all frames of one message id at once, with numpy."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pandas as pd

from superlane_tools.can.dbc import _signal_bits
from superlane_tools.can.errors import CanError

ID_MASK_29 = 0x1FFFFFFF
SIGNAL_COLUMNS = ("log_time_ns", "can_id", "message", "signal", "value", "unit", "label")


class FrameArrays(NamedTuple):
    """CAN frames as column arrays, the input of :func:`decode_frames`.

    Attributes:
        can_id: (N,) uint32 arbitration ids (no extended flag).
        data: (N, W) uint8 payloads, zero padded to the widest frame.
        dlc: (N,) payload lengths in bytes.
        log_time_ns: (N,) int64 log times, nanoseconds.
    """

    can_id: npt.NDArray[np.uint32]
    data: npt.NDArray[np.uint8]
    dlc: npt.NDArray[np.int64]
    log_time_ns: npt.NDArray[np.int64]


def frames_to_arrays(
    can_id: npt.ArrayLike,
    data: npt.NDArray[np.uint8] | Sequence[bytes],
    log_time_ns: npt.ArrayLike,
    dlc: npt.ArrayLike | None = None,
) -> FrameArrays:
    """Normalise ids, payloads (2-D array or list of bytes) and times into :class:`FrameArrays`.

    Raises:
        CanError: If the arrays disagree in length.
    """
    ids = np.asarray(can_id, dtype=np.int64).astype(np.uint32) & np.uint32(ID_MASK_29)
    times = np.asarray(log_time_ns, dtype=np.int64)
    if isinstance(data, np.ndarray) and data.ndim == 2:
        payload = np.ascontiguousarray(data, dtype=np.uint8)
        lengths = np.full(len(payload), payload.shape[1], dtype=np.int64)
    else:
        items = [bytes(d) for d in data]
        lengths = np.fromiter((len(d) for d in items), dtype=np.int64, count=len(items))
        width = int(lengths.max()) if items else 8
        joined = b"".join(d.ljust(width, b"\0") for d in items)
        payload = np.frombuffer(joined, dtype=np.uint8).reshape(len(items), width)
    if dlc is not None:
        lengths = np.minimum(np.asarray(dlc, dtype=np.int64), payload.shape[1])
    if not len(ids) == len(times) == len(payload):
        raise CanError(
            f"CAN arrays disagree: {len(ids)} ids, {len(payload)} payloads, {len(times)} times"
        )
    return FrameArrays(ids, payload, lengths, times)


class _Payload:
    """One message's payloads in the layouts the bit extraction needs (built lazily)."""

    def __init__(self, payload: npt.NDArray[np.uint8]) -> None:
        self.payload = payload
        self._little: npt.NDArray[np.uint64] | None = None
        self._big: npt.NDArray[np.uint64] | None = None
        self._bits: npt.NDArray[np.uint8] | None = None

    def raw(self, sig: Any) -> npt.NDArray[np.uint64]:
        """Return each frame's raw unsigned value of ``sig``."""
        if self.payload.shape[1] == 8:
            return self._raw_word(sig)
        if self._bits is None:
            self._bits = np.unpackbits(self.payload, axis=1, bitorder="little")
        positions = _signal_bits(sig)  # LSB first (Intel) or MSB first (Motorola)
        if sig.byte_order != "little_endian":
            positions = positions[::-1]
        raw = np.zeros(self.payload.shape[0], dtype=np.uint64)
        for weight, pos in enumerate(positions):
            raw |= self._bits[:, pos].astype(np.uint64) << np.uint64(weight)
        return raw

    def _raw_word(self, sig: Any) -> npt.NDArray[np.uint64]:
        """Shift-and-mask extraction on the payload read as one 64-bit word."""
        length = int(sig.length)
        mask = np.uint64((1 << length) - 1)
        if sig.byte_order == "little_endian":
            if self._little is None:
                self._little = self.payload.view("<u8").ravel().astype(np.uint64)
            return (self._little >> np.uint64(sig.start)) & mask
        if self._big is None:
            self._big = self.payload.view(">u8").ravel().astype(np.uint64)
        msb_from_left = 8 * (sig.start // 8) + 7 - sig.start % 8
        return (self._big >> np.uint64(64 - msb_from_left - length)) & mask


def _physical(raw: npt.NDArray[np.uint64], sig: Any) -> npt.NDArray[np.float64]:
    """Apply sign, float interpretation, scale and offset to raw values."""
    length = sig.length
    if sig.is_float:
        if length == 32:
            values = raw.astype(np.uint32).view(np.float32).astype(np.float64)
        else:
            values = raw.view(np.float64).copy()
    elif sig.is_signed:
        signed = raw.view(np.int64).copy()
        if length < 64:
            sign = (raw >> np.uint64(length - 1)) & np.uint64(1)
            signed -= sign.astype(np.int64) << np.int64(length)
        values = signed.astype(np.float64)
    else:
        values = raw.astype(np.float64)
    return values * float(sig.scale) + float(sig.offset)


class _Columns(NamedTuple):
    """Decoded rows of one signal: times, values, the signal's name index and ``VAL_`` labels."""

    times: npt.NDArray[np.int64]
    values: npt.NDArray[np.float64]
    label: int
    texts: npt.NDArray[np.object_] | None


def _choice_texts(raw: npt.NDArray[np.uint64], sig: Any) -> npt.NDArray[np.object_] | None:
    """Return the ``VAL_`` label of each raw value ("" where none), or None without a table."""
    choices = getattr(sig, "choices", None)
    if not choices:
        return None
    keys, inverse = np.unique(raw, return_inverse=True)
    names = np.array([str(choices.get(int(k), "")) for k in keys.tolist()], dtype=object)
    texts: npt.NDArray[np.object_] = names[inverse]
    return texts


def _decode_message(
    msg: Any, frames: FrameArrays, rows: npt.NDArray[np.intp], labels: list[tuple[Any, ...]]
) -> list[_Columns]:
    """Decode every signal of one message over the frames at ``rows``."""
    width = max(int(msg.length), 1)
    payload = frames.data[rows, :width]
    target = 8 if width <= 8 else width
    if payload.shape[1] < target:
        payload = np.pad(payload, ((0, 0), (0, target - payload.shape[1])))
    words = _Payload(np.ascontiguousarray(payload))
    lengths = frames.dlc[rows]
    times = frames.log_time_ns[rows]
    raws: dict[str, npt.NDArray[np.uint64]] = {}
    masks: dict[str, npt.NDArray[np.bool_]] = {}

    def raw_of(sig: Any) -> npt.NDArray[np.uint64]:
        if sig.name not in raws:
            raws[sig.name] = words.raw(sig)
        return raws[sig.name]

    def mask_of(sig: Any) -> npt.NDArray[np.bool_]:
        if sig.name in masks:
            return masks[sig.name]
        needed = max(_signal_bits(sig)) // 8 + 1
        mask = lengths >= needed  # a short frame does not carry this signal
        if sig.multiplexer_ids and sig.multiplexer_signal:
            mux = msg.get_signal_by_name(sig.multiplexer_signal)
            mask = mask & mask_of(mux) & np.isin(raw_of(mux), list(sig.multiplexer_ids))
        masks[sig.name] = mask
        return mask

    parts = []
    for sig in msg.signals:
        mask = mask_of(sig)
        if mask.all():
            raw, sel_times = raw_of(sig), times
        elif mask.any():
            raw, sel_times = raw_of(sig)[mask], times[mask]
        else:
            continue
        labels.append((msg.frame_id, msg.name, sig.name, sig.unit or ""))
        texts = _choice_texts(raw, sig)
        parts.append(_Columns(sel_times, _physical(raw, sig), len(labels) - 1, texts))
    return parts


def empty_signal_table() -> pd.DataFrame:
    """Return an empty long-form signal table with the right column types."""
    return pd.DataFrame(
        {
            "log_time_ns": np.zeros(0, dtype=np.int64),
            "can_id": np.zeros(0, dtype=np.uint32),
            "message": np.zeros(0, dtype=object),
            "signal": np.zeros(0, dtype=object),
            "value": np.zeros(0, dtype=np.float64),
            "unit": np.zeros(0, dtype=object),
            "label": np.zeros(0, dtype=object),
        }
    )


def decode_frames(
    db: Any,
    can_id: npt.ArrayLike,
    data: npt.NDArray[np.uint8] | Sequence[bytes],
    log_time_ns: npt.ArrayLike,
    dlc: npt.ArrayLike | None = None,
) -> pd.DataFrame:
    """Decode CAN frames into a long-form signal table, vectorised per message id.

    Every signal of a message is extracted from all frames of its id at once: bits are
    unpacked with numpy and reassembled in the signal's Intel (little-endian) or Motorola
    (big-endian, DBC sawtooth start bit) layout; then sign, float, scale and offset apply.
    Multiplexed signals are decoded only on frames whose multiplexer value selects them
    (nested multiplexers too). Frames too short for a signal yield no row for it. Ids the
    database does not know are ignored.

    Args:
        db: A ``cantools`` database (e.g. ``load_dbc(path).database``).
        can_id: (N,) arbitration ids; an extended flag in bit 31 is ignored.
        data: (N, W) uint8 payloads or a sequence of N ``bytes``.
        log_time_ns: (N,) log times, integer nanoseconds.
        dlc: Optional (N,) payload lengths in bytes (default: the payload widths).

    Returns:
        Columns ``log_time_ns`` (int64 ns), ``can_id`` (uint32), ``message``, ``signal``,
        ``value`` (float64, physical units), ``unit``, ``label`` (the ``VAL_`` enum label of
        the raw value, "" where the signal has none; categoricals for the names); rows ordered
        by time (stable).
    """
    frames = frames_to_arrays(can_id, data, log_time_ns, dlc)
    by_id = {msg.frame_id: msg for msg in db.messages}
    unique_ids, inverse = np.unique(frames.can_id, return_inverse=True)
    order = np.argsort(inverse, kind="stable")
    bounds = np.searchsorted(inverse[order], np.arange(len(unique_ids) + 1))
    labels: list[tuple[Any, ...]] = []
    parts: list[_Columns] = []
    for k, frame_id in enumerate(unique_ids.tolist()):
        msg = by_id.get(frame_id)
        if msg is None or not msg.signals:
            continue
        parts.extend(_decode_message(msg, frames, order[bounds[k] : bounds[k + 1]], labels))
    if not parts:
        return empty_signal_table()
    times = np.concatenate([p.times for p in parts])
    values = np.concatenate([p.values for p in parts])
    codes = np.concatenate([np.full(len(p.times), p.label, dtype=np.int32) for p in parts])
    texts = np.concatenate(
        [p.texts if p.texts is not None else np.full(len(p.times), "", object) for p in parts]
    )
    sort = np.argsort(times, kind="stable")
    times, values, codes, texts = times[sort], values[sort], codes[sort], texts[sort]
    ids = np.array([lab[0] for lab in labels], dtype=np.uint32)

    def column(index: int) -> pd.Categorical[str]:
        names = [str(lab[index]) for lab in labels]
        categories = sorted(set(names))
        lookup = np.array([categories.index(n) for n in names], dtype=np.int32)
        result: pd.Categorical[str] = pd.Categorical.from_codes(
            lookup[codes], categories=pd.Index(categories)
        )
        return result

    return pd.DataFrame(
        {
            "log_time_ns": times,
            "can_id": ids[codes],
            "message": column(1),
            "signal": column(2),
            "value": values,
            "unit": column(3),
            "label": pd.Categorical(texts),
        }
    )
