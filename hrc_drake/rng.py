"""Random generators as run state (the bottom layer, beside `messages`).

A core that keeps a `numpy.random.Generator` in a Context's state is cloned at every update
(copy-on-write, `hrc_drake.systems.Frozen`); `clone_generator` copies a generator in ~10 us, where
`copy.deepcopy` costs ~50-150 us and a fresh `PCG64()` ~35 us (it hashes a seed first).
"""

from __future__ import annotations

import numpy as np
from numpy.random.bit_generator import ISeedSequence


class _Blank(ISeedSequence):
    """A seed sequence that hashes nothing: the state is overwritten right after."""

    def generate_state(self, n_words, dtype=np.uint32):
        return np.zeros(n_words, dtype=dtype)


_BLANK = _Blank()


def clone_generator(rng: np.random.Generator) -> np.random.Generator:
    """An independent generator in the same state as `rng` (same draws from here on)."""
    bit = rng.bit_generator
    copy = type(bit)(_BLANK)
    copy.state = bit.state
    return np.random.Generator(copy)
