"""superlane-tools: reprocess driving recordings with the SUPER lane-detection stack."""

from superlane_tools._version import __version__
from superlane_tools.errors import ConfigError, ExitCode, SltError, UsageError
from superlane_tools.records import Message, RawMessage, Skipped, TopicInfo

__all__ = [
    "ConfigError",
    "ExitCode",
    "Message",
    "RawMessage",
    "Skipped",
    "SltError",
    "TopicInfo",
    "UsageError",
    "__version__",
]
