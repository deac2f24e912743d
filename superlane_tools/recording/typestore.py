"""The project's ROS message typestore: ROS 2 Humble plus driving types it lacks."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

CAN_FRAME_MSGTYPE = "can_msgs/msg/Frame"
"""ROS 2 name of the ``can_msgs`` CAN frame (ros-drivers/ros_canopen)."""

CAN_FRAME_MSG = """\
std_msgs/Header header
uint32 id
bool is_rtr
bool is_extended
bool is_error
uint8 dlc
uint8[8] data
"""
"""Message definition of ``can_msgs/msg/Frame``, as shipped by ``can_msgs``."""

COMPRESSED_VIDEO_MSGTYPE = "foxglove_msgs/msg/CompressedVideo"
"""ROS 2 name of Foxglove's compressed video message (``foxglove_msgs``)."""

COMPRESSED_VIDEO_MSG = """\
builtin_interfaces/Time timestamp
string frame_id
uint8[] data
string format
"""
"""Message definition of ``foxglove_msgs/msg/CompressedVideo``, as shipped by ``foxglove_msgs``."""

EXTRA_MSGDEFS: dict[str, str] = {
    CAN_FRAME_MSGTYPE: CAN_FRAME_MSG,
    COMPRESSED_VIDEO_MSGTYPE: COMPRESSED_VIDEO_MSG,
}
"""Message types registered on top of ROS 2 Humble, by ROS 2 name."""


@functools.cache
def default_typestore() -> Typestore:
    """Return the shared typestore: ROS 2 Humble plus :data:`EXTRA_MSGDEFS`.

    The store is cached and shared; do not register further types in it. Build a fresh one with
    :func:`new_typestore` for that.
    """
    return new_typestore()


def new_typestore() -> Typestore:
    """Build a fresh typestore with ROS 2 Humble plus :data:`EXTRA_MSGDEFS`."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    for msgtype, msgdef in EXTRA_MSGDEFS.items():
        store.register(get_types_from_msg(msgdef, msgtype))
    return store


@functools.cache
def ros1_typestore() -> Typestore:
    """Return the shared ROS 1 typestore: Noetic, plus :data:`EXTRA_MSGDEFS`, plus Humble types.

    It gives ROS 1 writers their genuine definitions and MD5 sums (``std_msgs/Header`` with
    ``seq``, ``CameraInfo`` with ``D``/``K``/``R``/``P``) and is the decoding fallback for
    ``ros1msg`` schemas that cannot be parsed. Types Noetic lacks (``tf2_msgs/msg/TFMessage``)
    come from ROS 2 Humble, so they nest the ROS 1 ``Header``. Do not register further types.
    """
    store = get_typestore(Stores.ROS1_NOETIC)
    typs = {}
    for msgtype, msgdef in EXTRA_MSGDEFS.items():
        typs.update(get_types_from_msg(msgdef, msgtype))
    for name, fielddef in get_typestore(Stores.ROS2_HUMBLE).fielddefs.items():
        if name not in store.fielddefs and name not in typs:
            typs[name] = fielddef
    store.register(typs)
    return store
