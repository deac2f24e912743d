"""Dataset adapters (label ids -> hierarchy nodes) and the hierarchy heads they train."""

from superlane_tools.scene.adapters.heads import (
    DEFAULT_LEAF,
    HEADS,
    IGNORE,
    NODE_CODES,
    NODE_NAMES,
    Head,
    codes_to_leaf,
    decode_heads,
    head_target_lut,
    head_targets,
    leaf_to_codes,
    validate_heads,
)
from superlane_tools.scene.adapters.loader import (
    SUPERLANE,
    DatasetAdapter,
    adapter_from_mapping,
    identity_adapter,
    list_adapters,
    load_adapter,
)

__all__ = [
    "DEFAULT_LEAF",
    "HEADS",
    "IGNORE",
    "NODE_CODES",
    "NODE_NAMES",
    "SUPERLANE",
    "DatasetAdapter",
    "Head",
    "adapter_from_mapping",
    "codes_to_leaf",
    "decode_heads",
    "head_target_lut",
    "head_targets",
    "identity_adapter",
    "leaf_to_codes",
    "list_adapters",
    "load_adapter",
    "validate_heads",
]
