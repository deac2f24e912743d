"""The one decoding step every source shares: raw messages in, decoded messages out.

Sources only read: each yields its raw messages keyed by what selects their decoder (an MCAP
channel, a ROS type name) and says which decoder a key takes. :func:`decode_messages` looks the
decoder up once per key, decodes, and counts what does not decode in one place: a key without a
decoder as ``unknown message type``, a payload its decoder rejects as ``undecodable message``.
(rosbags' ``AnyReader`` and mcap's ``iter_decoded_messages`` split reading and decoding the
same way.)
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Hashable, Iterable, Iterator
from typing import Any

from superlane_tools.recording.base import ClosingRecording, SkipLog, stamp_ns_of
from superlane_tools.records import Message, RawMessage

Decode = Callable[[RawMessage], Any]
"""Turns one raw message into a message object with attribute access (raises when it cannot)."""


class DecodeFailureError(Exception):
    """No decoder can be built for a key (a schema, a type name); the message says why."""


def decode_messages(
    keyed: Iterable[tuple[Hashable, RawMessage]],
    decoder_for: Callable[[Hashable, RawMessage], Decode],
    skips: SkipLog,
) -> Iterator[Message]:
    """Decode raw messages, skipping and counting those that do not decode.

    Args:
        keyed: ``(key, raw message)`` pairs; messages with the same key share a decoder.
        decoder_for: Return the decoder for a key (given its first message); raise
            :class:`DecodeFailureError` when there is none.
        skips: Where skipped messages are counted, per topic.

    Yields:
        The decoded messages, in the order of ``keyed``, ``stamp_ns`` read from the decoded
        message's header (ROS) or timestamp (Foxglove protobuf).
    """
    decoders: dict[Hashable, Decode | DecodeFailureError] = {}
    for key, raw in keyed:
        decode = decoders.get(key)
        if decode is None:  # look the decoder up once per key, not per message
            try:
                decode = decoder_for(key, raw)
            except DecodeFailureError as err:
                decode = err
            decoders[key] = decode
        if isinstance(decode, DecodeFailureError):
            skips.add("unknown message type", f"{raw.topic}: {decode}")
            continue
        try:
            data = decode(raw)
        except Exception as err:  # one bad payload must not end the stream
            skips.add("undecodable message", f"{raw.topic} ({raw.msgtype}): {type(err).__name__}")
            continue
        yield Message(raw.topic, raw.log_time_ns, stamp_ns_of(data), raw.msgtype, data)


class RawSource(ClosingRecording):
    """Base of the recording sources: they read raw messages, decoding is :func:`decode_messages`.

    A source implements :meth:`_keyed_raw` (its raw messages in log-time order with their
    decoder keys; it starts a new pass of :meth:`_pass_skips`), :meth:`_decoder_for` and
    :meth:`_pass_skips`.
    """

    def _keyed_raw(
        self, topics: Collection[str] | None, start_ns: int | None, stop_ns: int | None
    ) -> Iterator[tuple[Hashable, RawMessage]]:
        """Yield ``(decoder key, raw message)`` of ``topics`` in ``[start_ns, stop_ns)``."""
        raise NotImplementedError

    def _decoder_for(self, key: Hashable, raw: RawMessage) -> Decode:
        """Return the decoder of ``key``; raise :class:`DecodeFailureError` when there is none."""
        raise NotImplementedError

    def _pass_skips(self) -> SkipLog:
        """Return where the current message pass counts what it skips."""
        raise NotImplementedError

    def raw_messages(
        self,
        topics: Collection[str] | None = None,
        start_ns: int | None = None,
        stop_ns: int | None = None,
    ) -> Iterator[RawMessage]:
        """Yield undecoded messages in log-time order, ``[start_ns, stop_ns)``."""
        for _, raw in self._keyed_raw(topics, start_ns, stop_ns):
            yield raw

    def messages(
        self,
        topics: Collection[str] | None = None,
        start_ns: int | None = None,
        stop_ns: int | None = None,
    ) -> Iterator[Message]:
        """Yield decoded messages in log-time order; undecodable ones are counted as skipped."""
        keyed = self._keyed_raw(topics, start_ns, stop_ns)
        return decode_messages(keyed, self._decoder_for, self._pass_skips())
