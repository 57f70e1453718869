"""Variable-order Markov model: prediction by partial match (baseline of Fig. 5.4).

After Begleiter, El-Yaniv and Yona (JAIR 2004), PPM with escape method C in its interpolated
(blended) form, which normalises without exclusion:

    P(a | s) = (N(s a) + E(s) P(a | s')) / (N(s) + E(s)),   E(s) = #distinct actions seen after s,

s' being s without its oldest action, down to the empty context and an order -1 uniform
distribution. Counts of every context up to `max_depth` live in a dict, so memory grows
linearly with the FIFO length (as the thesis notes).
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence

import numpy as np

from .base import SequenceModel


class VariableOrderMarkovModel(SequenceModel):
    """PPM-C variable-order Markov model with contexts up to `max_depth` actions.

    Learned: contexts_ dict context tuple (oldest first) -> (m,) counts of the following action.
    """

    def __init__(
        self,
        max_depth: int = 5,
        buffer_size: int | None = 200,
        actions: int | Sequence[Hashable] | None = None,
    ):
        super().__init__(actions=actions, buffer_size=buffer_size)
        self.max_depth = max_depth

    @property
    def context_length_(self) -> int:
        return int(self.max_depth)

    def _params(self) -> dict:
        return {"max_depth": self.max_depth, "buffer_size": self.buffer_size}

    def _reset_state(self) -> None:
        if int(self.max_depth) < 0:
            raise ValueError(f"{type(self).__name__}: max_depth={self.max_depth} must be >= 0")
        self.contexts_: dict[tuple[int, ...], np.ndarray] = {}

    def _clone_state(self) -> None:
        # the count arrays are replaced, never written in place: a shallow copy of the dict will do
        self.contexts_ = dict(self.contexts_)

    def _add(self, context: tuple[int, ...], code: int, amount: float) -> None:
        counts = self.contexts_.get(context)
        counts = np.zeros(self.n_actions_) if counts is None else counts.copy()
        counts[code] += amount
        if amount < 0 and counts.sum() <= 0:
            self.contexts_.pop(context, None)
        else:
            self.contexts_[context] = counts

    def _learn_newest(self) -> None:
        buffer = self.buffer_
        newest = len(buffer) - 1
        code = buffer[newest]
        for depth in range(min(int(self.max_depth), newest) + 1):
            context = tuple(buffer[i] for i in range(newest - depth, newest))
            self._add(context, code, 1.0)

    def _forget_oldest(self) -> None:
        # every n-gram holding the oldest action starts with it
        buffer = self.buffer_
        for depth in range(min(int(self.max_depth), len(buffer) - 1) + 1):
            context = tuple(buffer[i] for i in range(depth))
            self._add(context, buffer[depth], -1.0)

    def _predict_codes(self, context: tuple[int, ...]) -> np.ndarray:
        probs = np.full(self.n_actions_, 1.0 / self.n_actions_)
        for depth in range(min(len(context), int(self.max_depth)) + 1):
            counts = self.contexts_.get(tuple(context[len(context) - depth :]))
            if counts is None:
                break
            escapes = float(np.count_nonzero(counts))
            probs = (counts + escapes * probs) / (counts.sum() + escapes)
        return probs
