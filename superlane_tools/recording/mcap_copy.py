"""Byte-for-byte copying of MCAP messages into another MCAP writer (filter, recover)."""

from __future__ import annotations

from typing import Any


class McapCopier:
    """Copies messages from an MCAP reader into an MCAP writer, byte for byte.

    Schemas and channels (with their metadata) are registered in the writer the first time a
    message of theirs is copied.
    """

    def __init__(self, writer: Any) -> None:
        self._writer = writer
        self._schemas: dict[int, int] = {}
        self._channels: dict[int, int] = {}

    def add(self, schema: Any, channel: Any, message: Any) -> None:
        """Copy one ``(schema, channel, message)`` as the mcap reader yields them."""
        cid = self._channels.get(channel.id)
        if cid is None:
            sid = 0
            if schema is not None:
                if schema.id not in self._schemas:
                    self._schemas[schema.id] = self._writer.register_schema(
                        schema.name, schema.encoding, schema.data
                    )
                sid = self._schemas[schema.id]
            cid = self._writer.register_channel(
                channel.topic, channel.message_encoding, sid, dict(channel.metadata)
            )
            self._channels[channel.id] = cid
        self._writer.add_message(
            cid, message.log_time, message.data, message.publish_time, message.sequence
        )
