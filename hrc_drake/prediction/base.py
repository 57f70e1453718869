"""Shared machinery of the activity-sequence models of thesis Ch. 5.

Every model predicts the next action A_{k+1} from the recent actions A_k, A_{k-1}, ...
(eq. 5.1). Actions are ints 0..m-1 or arbitrary hashable labels; the model maps labels to
column indices (`classes_`). Models learn from a FIFO buffer of recent actions (Fig. 5.1):
`buffer_size=None` keeps everything observed.
"""

from __future__ import annotations

import itertools
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Hashable, Iterable, Sequence

import numpy as np

from hrc_drake.messages import shallow_copy

#: every change of a model's learned state takes a fresh id, so caches keyed on it never go stale
_STATE_IDS = itertools.count(1)


#: model class name -> class, for `SequenceModel.from_dict`
_MODEL_CLASSES: dict[str, type] = {}


def recent(codes: tuple[int, ...], width: int) -> tuple[int, ...]:
    """The last `width` codes: all of them when there are fewer, none for width 0."""
    # not codes[len(codes) - width:]: a history shorter than the context would then start at a
    # negative index and lose its oldest actions
    return codes[max(len(codes) - width, 0) :]


def _plain(label):
    """numpy scalars hash like Python scalars only after conversion."""
    return label.item() if isinstance(label, np.generic) else label


class SequenceModel(ABC):
    """Base of the next-action models: label mapping, FIFO buffer, multi-step prediction.

    actions: the action set: an int m (actions 0..m-1), a sequence of labels, or None to
        learn the labels at `fit` (non-negative ints give 0..max, other labels are sorted).
    buffer_size: length of the FIFO buffer of past actions the model learns from (None:
        unbounded).

    Subclasses implement `_reset_state`, `_learn_newest`, `_forget_oldest`, `_update_fit`,
    `_predict_codes` and `context_length_`.
    """

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        _MODEL_CLASSES[cls.__name__] = cls

    def __init__(self, actions: int | Sequence[Hashable] | None = None, buffer_size: int | None = None):
        self.actions = actions
        self.buffer_size = buffer_size

    # ---------------------------------------------------------------- label mapping
    def _set_classes(self, classes: Sequence[Hashable]) -> None:
        classes = [_plain(c) for c in classes]
        if len(classes) < 1:
            raise ValueError(f"{type(self).__name__}: the action set is empty")
        if len(set(classes)) != len(classes):
            raise ValueError(f"{type(self).__name__}: duplicate action labels in {classes!r}")
        self.classes_ = list(classes)
        self.n_actions_ = len(classes)
        self._code_of = {c: i for i, c in enumerate(self.classes_)}

    def _classes_from_actions(self, sequence: Sequence[Hashable] | None) -> list:
        if self.actions is not None:
            if isinstance(self.actions, (int, np.integer)):
                if self.actions < 1:
                    raise ValueError(f"{type(self).__name__}: actions={self.actions} must be >= 1")
                return list(range(int(self.actions)))
            return list(self.actions)
        if sequence is None:
            from sklearn.exceptions import NotFittedError  # lazy: scikit-learn is slow to import

            raise NotFittedError(
                f"{type(self).__name__}: the action set is unknown; pass actions= or call fit first"
            )
        labels = {_plain(a) for a in sequence}
        if all(isinstance(a, int) and not isinstance(a, bool) and a >= 0 for a in labels):
            return list(range(max(labels) + 1)) if labels else []
        try:
            return sorted(labels)
        except TypeError as err:
            raise ValueError(
                f"{type(self).__name__}: action labels must be sortable or given as actions="
            ) from err

    def encode(self, labels: Iterable[Hashable]) -> tuple[int, ...]:
        """Column indices of `labels`; ValueError naming the first unknown label."""
        self._check_classes()
        codes = []
        for position, label in enumerate(labels):
            try:
                codes.append(self._code_of[_plain(label)])
            except (KeyError, TypeError):
                raise ValueError(
                    f"{type(self).__name__}: unknown action {label!r} at position {position}; "
                    f"known actions: {self.classes_!r}"
                ) from None
        return tuple(codes)

    def _check_classes(self) -> None:
        if not hasattr(self, "classes_"):
            self._set_classes(self._classes_from_actions(None))
            self._reset()

    # ---------------------------------------------------------------- copy-on-write
    def clone(self):
        """A copy that `partial_fit` may change without touching this model (copy-on-write).

        Shares what an update never writes in place (parameters, label maps, arrays that are
        only ever replaced, memo caches keyed on `state_id_`); copies the FIFO buffer and what
        `_clone_state` names. Cheaper than a deep copy (used by the Drake systems' state).
        """
        new = shallow_copy(self)
        if hasattr(self, "buffer_"):
            new.buffer_ = deque(self.buffer_)
            new._clone_state()
        return new

    def _clone_state(self) -> None:  # noqa: B027 - optional hook
        """Replace, on a fresh shallow copy, every container `_learn_newest` writes in place."""

    # ---------------------------------------------------------------- learning
    def _reset(self) -> None:
        if self.buffer_size is not None and int(self.buffer_size) < 1:
            raise ValueError(f"{type(self).__name__}: buffer_size={self.buffer_size} must be >= 1 or None")
        self.buffer_ = deque()
        self.n_observed_ = 0
        self._reset_state()
        self._touch()

    def _touch(self) -> None:
        self.state_id_ = next(_STATE_IDS)

    def _observe(self, code: int) -> None:
        limit = self._buffer_limit()
        if limit is not None and len(self.buffer_) >= limit:
            self._forget_oldest()
            self.buffer_.popleft()
        self.buffer_.append(code)
        self.n_observed_ += 1
        self._learn_newest()
        self._touch()

    def _buffer_limit(self) -> int | None:
        return None if self.buffer_size is None else int(self.buffer_size)

    def fit(self, sequence: Sequence[Hashable]):
        """Learn from a whole sequence of actions (oldest first); returns self."""
        sequence = list(sequence)
        self._set_classes(self._classes_from_actions(sequence))
        self._reset()
        for code in self.encode(sequence):
            self._observe(code)
        self._update_fit(final=True)
        self._touch()
        return self

    def partial_fit(self, action: Hashable):
        """Observe one more action and refit online; returns self."""
        self._check_classes()
        (code,) = self.encode([action])
        self._observe(code)
        self._update_fit(final=False)
        self._touch()
        return self

    # ---------------------------------------------------------------- prediction
    def predict_proba(self, history: Sequence[Hashable]) -> np.ndarray:
        """P(A_{k+1} = a | history) over `classes_`; history is oldest first, ends with A_k.

        Fallbacks (documented): with nothing observed yet but a known action set, the uniform
        distribution; an empty history gives the model's marginal over the buffer.
        """
        codes = self.encode(history)
        if self.n_observed_ == 0:
            return np.full(self.n_actions_, 1.0 / self.n_actions_)
        return self._predict_codes(recent(codes, self.context_length_))

    def predict_proba_many(self, histories: Sequence[Sequence[Hashable]]) -> np.ndarray:
        """`predict_proba` of many histories in one vectorised call, shape (N, m)."""
        self._check_classes()
        width = self.context_length_
        contexts = []
        for index, history in enumerate(histories):
            try:
                codes = self.encode(history)
            except ValueError as err:
                raise ValueError(f"histories[{index}]: {err}") from None
            contexts.append(recent(codes, width))
        if not contexts:
            return np.zeros((0, self.n_actions_))
        if self.n_observed_ == 0:
            return np.full((len(contexts), self.n_actions_), 1.0 / self.n_actions_)
        return self._predict_many(contexts)

    def predict_proba_steps(self, history: Sequence[Hashable], steps: int) -> np.ndarray:
        """P(A_{k+steps} = a | history), summing over the intermediate actions, eqs. (5.14)-(5.15)."""
        if int(steps) < 1:
            raise ValueError(f"{type(self).__name__}: steps={steps} must be >= 1")
        codes = self.encode(history)
        if self.n_observed_ == 0:
            return np.full(self.n_actions_, 1.0 / self.n_actions_)
        width = self.context_length_
        contexts = {recent(codes, width): 1.0}
        out = np.zeros(self.n_actions_)
        for step in range(int(steps)):
            last = step == int(steps) - 1
            following: dict[tuple, float] = {}
            for context, weight in contexts.items():
                probs = self._predict_codes(context)
                if last:
                    out += weight * probs
                    continue
                for action in np.flatnonzero(probs > 0.0):
                    key = (context + (int(action),))[-width:]
                    following[key] = following.get(key, 0.0) + weight * probs[action]
            contexts = following
        return out

    def _predict_many(self, contexts: list[tuple[int, ...]]) -> np.ndarray:
        """Next-action probabilities (N, m) for many code contexts (each at most context_length_)."""
        return np.stack([self._predict_codes(ctx) for ctx in contexts])

    def marginal_(self) -> np.ndarray:
        """Relative frequency of each action in the buffer (uniform when empty)."""
        if not self.buffer_:
            return np.full(self.n_actions_, 1.0 / self.n_actions_)
        counts = np.bincount(np.fromiter(self.buffer_, dtype=int), minlength=self.n_actions_)
        return counts / counts.sum()

    # ---------------------------------------------------------------- hooks
    context_length_: int = 1

    @abstractmethod
    def _reset_state(self) -> None:
        """Forget everything learned (counts, tokens, weights)."""

    @abstractmethod
    def _learn_newest(self) -> None:
        """Learn from the newest action in the buffer."""

    @abstractmethod
    def _forget_oldest(self) -> None:
        """Unlearn the action about to leave the FIFO buffer."""

    def _update_fit(self, final: bool) -> None:  # noqa: B027 - optional hook, most models have nothing to refit
        """Refit what depends on the whole buffer (weights); `final` after a batch `fit`."""

    @abstractmethod
    def _predict_codes(self, context: tuple[int, ...]) -> np.ndarray:
        """Next-action probabilities (m,) after the context of action codes."""

    # ---------------------------------------------------------------- persistence
    def to_dict(self) -> dict:
        """JSON-ready description: class, parameters, labels, buffered actions, learned state.

        `SequenceModel.from_dict` rebuilds an equal model from it (labels must be JSON
        scalars: str, int, float, bool).
        """
        self._check_classes()
        return {
            "model": type(self).__name__,
            "params": self._params(),
            "classes": list(self.classes_),
            "buffer": [self.classes_[c] for c in self.buffer_],
            "n_observed": int(self.n_observed_),
            "state": self._state_to_dict(),
        }

    @classmethod
    def from_dict(cls, data: dict):
        """Rebuild a model saved with `to_dict` (parsed JSON). ValueError on bad data."""
        if not isinstance(data, dict):
            raise ValueError(f"{cls.__name__}.from_dict: expected a dict, got {type(data).__name__}")
        missing = [key for key in ("model", "params", "classes", "buffer") if key not in data]
        if missing:
            raise ValueError(f"{cls.__name__}.from_dict: missing keys {missing}")
        target = _MODEL_CLASSES.get(data["model"])
        if target is None or not issubclass(target, cls):
            raise ValueError(f"{cls.__name__}.from_dict: unknown model {data['model']!r}")
        try:
            model = target(actions=list(data["classes"]), **dict(data["params"]))
            model._set_classes(model._classes_from_actions(None))
            model._reset()
            codes = model.encode(data["buffer"])
            model._restore(codes, int(data.get("n_observed", len(codes))), data.get("state") or {})
        except (TypeError, KeyError) as err:
            raise ValueError(f"{cls.__name__}.from_dict: malformed {data['model']} data: {err!r}") from None
        model._touch()
        return model

    def _params(self) -> dict:
        return {"buffer_size": self.buffer_size}

    def _state_to_dict(self) -> dict:
        """Learned values that are not a function of the buffer (none by default)."""
        return {}

    def _restore(self, codes: tuple[int, ...], n_observed: int, state: dict) -> None:
        """Replay the buffer (the counts depend only on it), then restore the step counter."""
        for code in codes:
            self._observe(code)
        self.n_observed_ = max(n_observed, len(codes))
