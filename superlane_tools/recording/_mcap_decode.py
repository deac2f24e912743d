"""Pluggable decoding of MCAP message payloads: mcap decoder factories, rosbags fallback, JSON."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

from superlane_tools.recording.base import msgdef_starts_with_header, ros2_msgtype
from superlane_tools.recording.decoding import DecodeFailureError

if TYPE_CHECKING:
    from mcap.decoder import DecoderFactory
    from mcap.records import Schema
    from rosbags.typesys.store import Typestore

Decoder = Callable[[bytes], Any]
"""Turns one serialized payload into a message object with attribute access."""

ROS_SCHEMA_ENCODINGS = {"ros2msg", "ros2idl", "ros1msg"}


def msgtype_name(schema: Schema | None, message_encoding: str) -> str:
    """Return the message type name of a channel: ROS 2 form for ROS schemas, else as stored."""
    if schema is None or not schema.name:
        return f"<schemaless {message_encoding}>"
    if schema.encoding in ROS_SCHEMA_ENCODINGS:
        return ros2_msgtype(schema.name)
    return schema.name


def header_first(schema: Schema | None, message_encoding: str) -> bool:
    """Return True when a ROS channel's type starts with a ``std_msgs/Header`` field."""
    if schema is None or message_encoding not in {"cdr", "ros1"}:
        return False
    if schema.encoding not in {"ros2msg", "ros1msg"}:
        return False
    try:
        return msgdef_starts_with_header(schema.data.decode("utf-8", errors="replace"))
    except ValueError:
        return False


def _json_decoder(data: bytes) -> Any:
    return json.loads(data, object_hook=lambda obj: SimpleNamespace(**obj))


class McapDecoders:
    """Builds and caches one decoder per (message encoding, schema) of an MCAP file.

    Decoding tries the injected decoder factories first, in order, then the built-in mcap
    decoder factories (``mcap_ros2``, ``mcap_ros1``, ``mcap_protobuf``), which use the schemas
    stored in the file. When a ROS schema cannot be parsed, it falls back to the rosbags
    typestore definition of the same type name.

    Args:
        factories: Extra decoder factories (mcap's ``DecoderFactory`` interface: a factory
            returns a decoder for the encodings and schemas it knows, None for the others).
    """

    def __init__(self, factories: Sequence[DecoderFactory] = ()) -> None:
        from mcap_protobuf.decoder import DecoderFactory as ProtobufFactory
        from mcap_ros1.decoder import DecoderFactory as Ros1Factory
        from mcap_ros2.decoder import DecoderFactory as Ros2Factory

        self._factories = {
            "cdr": Ros2Factory(),
            "ros1": Ros1Factory(),
            "protobuf": ProtobufFactory(),
        }
        self._injected = tuple(factories)
        self._cache: dict[tuple[str, int], Decoder | DecodeFailureError] = {}
        self._ros2_store: Typestore | None = None
        self._ros1_store: Typestore | None = None

    def decoder_for(self, message_encoding: str, schema: Schema | None) -> Decoder:
        """Return the decoder for a channel.

        Raises:
            DecodeFailureError: If no decoder can be built; the reason is in the message.
        """
        key = (message_encoding, schema.id if schema is not None else 0)
        cached = self._cache.get(key)
        if cached is None:
            try:
                cached = self._build(message_encoding, schema)
            except DecodeFailureError as err:
                cached = err
            self._cache[key] = cached
        if isinstance(cached, DecodeFailureError):
            raise cached
        return cached

    def _build(self, message_encoding: str, schema: Schema | None) -> Decoder:
        injected = self._injected_decoder(message_encoding, schema)
        if injected is not None:
            return injected
        if message_encoding == "json":
            return _json_decoder
        factory = self._factories.get(message_encoding)
        if factory is None:
            raise DecodeFailureError(f"unsupported message encoding {message_encoding!r}")
        if schema is None:
            raise DecodeFailureError(f"{message_encoding} channel without a schema")
        error = "no decoder for this schema encoding"
        try:
            decoder = factory.decoder_for(message_encoding, schema)
        except Exception as err:  # a schema the factory cannot parse; try the fallback
            error = f"{type(err).__name__}: {err}"
            decoder = None
        if decoder is not None:
            return decoder
        fallback = self._typestore_decoder(message_encoding, schema)
        if fallback is not None:
            return fallback
        raise DecodeFailureError(f"cannot decode {schema.encoding} schema {schema.name!r}: {error}")

    def _injected_decoder(self, message_encoding: str, schema: Schema | None) -> Decoder | None:
        """Return the first injected factory's decoder for the channel, or None."""
        for factory in self._injected:
            try:
                decoder = factory.decoder_for(message_encoding, schema)
            except Exception as err:  # an injected factory that cannot parse the schema
                name = schema.name if schema is not None else message_encoding
                raise DecodeFailureError(
                    f"{type(factory).__name__} cannot decode {name!r}: {type(err).__name__}: {err}"
                ) from err
            if decoder is not None:
                return decoder
        return None

    def _typestore_decoder(self, message_encoding: str, schema: Schema) -> Decoder | None:
        """Decode with the rosbags typestore's own definition of the schema's type name."""
        msgtype = ros2_msgtype(schema.name)
        if message_encoding == "cdr" and schema.encoding in {"ros2msg", "ros2idl"}:
            if self._ros2_store is None:
                from superlane_tools.recording.typestore import default_typestore

                self._ros2_store = default_typestore()
            store = self._ros2_store
            if msgtype in store.fielddefs:
                return lambda data: store.deserialize_cdr(data, msgtype)
        if message_encoding == "ros1" and schema.encoding == "ros1msg":
            if self._ros1_store is None:
                from superlane_tools.recording.typestore import ros1_typestore

                self._ros1_store = ros1_typestore()
            store1 = self._ros1_store
            if msgtype in store1.fielddefs:
                return lambda data: store1.deserialize_ros1(data, msgtype)
        return None
