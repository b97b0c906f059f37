"""PyTorch access to CRAFT-format datasets (the optional ``torch`` extra: torch and PyAV).

>>> from torch.utils.data import DataLoader                                        # doctest: +SKIP
>>> from craft_dsl.torch import CraftVideoQA, collate                              # doctest: +SKIP
>>> train = CraftVideoQA("my_craft", "train", fps=5, size=128)                     # doctest: +SKIP
>>> batch = next(iter(DataLoader(train, batch_size=8, collate_fn=collate)))        # doctest: +SKIP
>>> batch["frames"].shape, batch["answer_index"], batch["program_ids"].shape       # doctest: +SKIP

Fresh questions without end, generated on the fly (:class:`CraftStream`, :func:`hf_stream`):

>>> stream = CraftStream(seed=1234, fps=5, size=128)                               # doctest: +SKIP
>>> batch = next(iter(DataLoader(stream, batch_size=8, collate_fn=collate, num_workers=2)))  # doctest: +SKIP

See ``docs/dataset-users.md`` and ``docs/train.md``.
"""

from __future__ import annotations

try:
    import torch  # noqa: F401
except ImportError as err:  # pragma: no cover - depends on the environment
    from ..errors import MissingExtraError

    raise MissingExtraError("craft_dsl.torch", "torch", "PyTorch") from err

from .dataset import FRAME_MODES, PAD, UNK, CraftVideoQA, collate
from .stream import STREAM_FRAME_MODES, CraftStream, hf_stream, stream_answers, stream_tokens
from .video import decode_image, decode_video

__all__ = ["FRAME_MODES", "PAD", "STREAM_FRAME_MODES", "UNK", "CraftStream", "CraftVideoQA", "collate",
           "decode_image", "decode_video", "hf_stream", "stream_answers", "stream_tokens"]
