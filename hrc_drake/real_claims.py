"""Claims of the real-recording bench fixed before it runs (`docs/real_claims.yaml`, issue 56): the
people split of each recording set into tuning and test people, and each claim's bench key, data
and rule. `evaluate` turns the bench's figures into one verdict per claim with its interval.

A rule `below: x` holds when the key's 95 % interval lies below x, does not hold when it lies at
or above x, and is inconclusive when it straddles x; `above: x` the other way round. A claim whose
key the bench did not measure is "not measured", never a verdict.
"""

from __future__ import annotations

import datetime
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from hrc_drake.untrusted import load_unique_yaml

#: the file the bench reads by default
CLAIMS_FILE = Path(__file__).resolve().parents[1] / "docs" / "real_claims.yaml"
VERDICTS = ("holds", "does not hold", "inconclusive", "not measured")
SPLITS = ("tuning", "test")
#: fewer people than this give no verdict: an interval over 2-4 people covers far less than 95 %
MIN_PEOPLE = 5
_KEY = re.compile(r"[A-Za-z0-9_]+(\.[A-Za-z0-9_]+)*")
_NAME = re.compile(r"[A-Za-z0-9_]+")
_MAX_BYTES = 200_000


class ClaimsError(ValueError):
    """A claims file that cannot be read as the bench needs it; the message names file and field."""


@dataclass(frozen=True)
class Claim:
    """One pre-registered claim: its bench key, the data, the rule (`below` or `above`), when it
    was registered, and for a later entry which claim it replaces and why."""

    id: str
    thesis: str
    key: str
    data: str
    registered: str
    people: str = "test"
    below: float | None = None
    above: float | None = None
    replaces: str = ""
    why: str = ""

    @property
    def rule(self) -> str:
        return f"< {self.below:g}" if self.below is not None else f"> {self.above:g}"


@dataclass(frozen=True)
class Claims:
    """A claims file: when it was registered, the people of each set by split, the claims."""

    registered: str
    people: dict
    claims: tuple[Claim, ...]

    def people_of(self, dataset: str, split: str) -> tuple[str, ...]:
        """The participants of `dataset` in `split` ("tuning", "test" or "all")."""
        if dataset not in self.people:
            raise ClaimsError(f"the claims file splits no people of {dataset!r}; "
                              f"it has {sorted(self.people)}")
        if split == "all":
            return tuple(sorted(self.people[dataset]["tuning"] + self.people[dataset]["test"]))
        if split not in SPLITS:
            raise ClaimsError(f"split must be one of {[*SPLITS, 'all']}, got {split!r}")
        return self.people[dataset][split]


def _date(value, where: str) -> str:
    text = str(value)
    try:
        datetime.date.fromisoformat(text)
    except ValueError:
        raise ClaimsError(f"{where}: {text!r} is not a date YYYY-MM-DD") from None
    return text


def _text(entry: dict, field: str, where: str, required: bool = True) -> str:
    value = entry.get(field, "")
    if not isinstance(value, str) or (required and not value.strip()):
        raise ClaimsError(f"{where}.{field}: must be {'non-empty ' if required else ''}text")
    if any(ord(c) < 32 for c in value):
        raise ClaimsError(f"{where}.{field}: control characters are not allowed")
    return value


def _claim(entry, where: str, earlier: dict) -> Claim:
    if not isinstance(entry, dict):
        raise ClaimsError(f"{where}: must be a mapping")
    known = {"id", "thesis", "key", "data", "people", "below", "above", "registered", "replaces", "why"}
    unknown = sorted(set(entry) - known)
    if unknown:
        raise ClaimsError(f"{where}: unknown fields {unknown}; known: {sorted(known)}")
    ident = _text(entry, "id", where)
    if not _NAME.fullmatch(ident) or ident in earlier:
        raise ClaimsError(f"{where}.id: {ident!r} must be letters, digits and _ and unique")
    key = _text(entry, "key", where)
    if not _KEY.fullmatch(key):
        raise ClaimsError(f"{where}.key: {key!r} is not a bench key (names joined by '.')")
    bounds = {b: entry[b] for b in ("below", "above") if b in entry}
    if len(bounds) != 1:
        raise ClaimsError(f"{where}: give exactly one rule, below or above")
    (side, bound), = bounds.items()
    if isinstance(bound, bool) or not isinstance(bound, (int, float)) or not math.isfinite(bound):
        raise ClaimsError(f"{where}.{side}: {bound!r} must be a finite number")
    replaces = _text(entry, "replaces", where, required=False)
    why = _text(entry, "why", where, required=False)
    if replaces and (replaces not in earlier or not why.strip()):
        raise ClaimsError(f"{where}.replaces: {replaces!r} must name an earlier claim, with a `why`")
    people = entry.get("people")
    if people not in (*SPLITS, "all"):
        raise ClaimsError(f"{where}.people: {people!r} must say whose figures judge it: tuning, test or all")
    registered = _date(entry.get("registered", ""), f"{where}.registered")
    if replaces and registered < earlier[replaces].registered:
        raise ClaimsError(f"{where}.registered: a replacement cannot predate the claim it replaces")
    return Claim(ident, _text(entry, "thesis", where), key, _text(entry, "data", where), registered, people,
                 float(bound) if side == "below" else None, float(bound) if side == "above" else None,
                 replaces, why)


def load_claims(path: str | Path = CLAIMS_FILE) -> Claims:
    """Read and check a claims file (YAML, safe loader, at most 200 kB)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as err:
        raise ClaimsError(f"{path}: cannot be read ({err.strerror})") from None
    if len(data) > _MAX_BYTES:
        raise ClaimsError(f"{path}: {len(data)} bytes, more than a claims file's {_MAX_BYTES}")
    try:
        document = load_unique_yaml(data.decode("utf-8"))
    except (UnicodeDecodeError, yaml.YAMLError) as err:
        raise ClaimsError(f"{path}: not UTF-8 YAML ({err})") from None
    if not isinstance(document, dict) or set(document) != {"registered", "people", "claims"}:
        raise ClaimsError(f"{path}: needs exactly the keys registered, people and claims")
    registered = _date(document["registered"], f"{path}: registered")
    people = {}
    if not isinstance(document["people"], dict):
        raise ClaimsError(f"{path}: people must map each recording set to its tuning and test people")
    for dataset, split in document["people"].items():
        where = f"{path}: people.{dataset}"
        if not isinstance(split, dict) or set(split) != set(SPLITS):
            raise ClaimsError(f"{where}: needs exactly tuning and test")
        names = {}
        for part in SPLITS:
            listed = split[part]
            names_ok = isinstance(listed, list) and all(
                isinstance(n, str) and _NAME.fullmatch(n) for n in listed)
            if not names_ok:
                raise ClaimsError(f"{where}.{part}: must be a list of participant names")
            names[part] = tuple(listed)
        both = set(names["tuning"]) & set(names["test"])
        if both or len(set(names["test"])) != len(names["test"]) or not names["test"]:
            raise ClaimsError(f"{where}: test people must be listed once, not empty, none also tuning "
                              f"(both: {sorted(both)})")
        people[str(dataset)] = names
    if not isinstance(document["claims"], list) or not document["claims"]:
        raise ClaimsError(f"{path}: claims must be a non-empty list")
    claims: dict[str, Claim] = {}
    for k, entry in enumerate(document["claims"]):
        claim = _claim(entry, f"{path}: claims[{k}]", claims)
        claims[claim.id] = claim
    return Claims(registered, people, tuple(claims.values()))


def verdict(claim: Claim, ci95) -> str:
    """The verdict of `claim` from its key's 95 % interval (low, high); "not measured" for None."""
    if ci95 is None:
        return "not measured"
    low, high = (float(v) for v in ci95)
    if not (math.isfinite(low) and math.isfinite(high)):
        return "not measured"
    if claim.below is not None:
        return "holds" if high < claim.below else "does not hold" if low >= claim.below else "inconclusive"
    return "holds" if low > claim.above else "does not hold" if high <= claim.above else "inconclusive"


def evaluate(claims: Claims, figures: dict, people: str) -> dict:
    """Each claim's verdict from the bench's flat figures (key -> estimate, key + ".ci95" ->
    [low, high], key + ".people" -> how many people the interval is over), run on the `people`
    selection: id -> {key, rule, people, estimate, ci95, verdict, why, registered (, replaces)}.
    A claim on other people than the run's is "not measured" (a held-out folder's people, "folder",
    count as test people); one whose interval is over fewer than `MIN_PEOPLE` people is
    "inconclusive"."""
    out = {}
    for claim in claims.claims:
        ci95 = figures.get(f"{claim.key}.ci95")
        n_people = figures.get(f"{claim.key}.people")
        estimate = figures.get(claim.key)
        # another folder's people (held out, `--data`) are test people: nothing was tuned on them
        if claim.people != people and not (claim.people == "test" and people == "folder"):
            result, why = ("not measured",
                           f"the claim is on {_whose(claim.people)}, the run on {_whose(people)}")
        elif estimate is None:
            result, why = "not measured", "the run has no figure for it"
        elif n_people is None or n_people < MIN_PEOPLE:
            result, why = "inconclusive", f"{n_people} people, fewer than {MIN_PEOPLE}"
        else:
            result, why = verdict(claim, ci95), ""
        entry = {"key": claim.key, "rule": claim.rule, "people": claim.people,
                 "estimate": estimate, "ci95": ci95, "people_in_interval": n_people,
                 "verdict": result, "why": why,
                 "registered": claim.registered}
        if claim.replaces:
            entry["replaces"] = claim.replaces
        out[claim.id] = entry
    return out


def _whose(selection: str) -> str:
    return "every participant" if selection in ("all", "folder") else f"the {selection} people"


def people_interval(values, counts=None) -> tuple[float | None, list | None, int]:
    """The mean over people of their values, its 95 % interval and the number of people: Student's
    t over the per-person values (the person is the unit), widened, for a proportion, to the exact
    (Clopper-Pearson) interval of the pooled counts (`counts`: (events, trials)), so that people
    who all show 0 do not give an interval of width 0, and kept within [0, 1]. (None, None, n) when
    a value is not finite
    or fewer than two people have one."""
    from scipy import stats

    values = np.asarray([v for v in values], dtype=float)
    n = int(len(values))
    if n < 2 or not np.all(np.isfinite(values)):
        return (float(values.mean()) if n and np.all(np.isfinite(values)) else None), None, n
    mean = float(values.mean())
    half = float(stats.t.ppf(0.975, n - 1) * values.std(ddof=1) / math.sqrt(n))
    low, high = mean - half, mean + half
    if counts is not None:
        events, trials = (int(c) for c in counts)
        if trials > 0:
            exact = stats.binomtest(events, trials).proportion_ci(0.95, method="exact")
            low, high = min(low, exact.low), max(high, exact.high)
        low, high = max(low, 0.0), min(high, 1.0)  # a proportion
    return mean, [low, high], n


#: the people selections a real-data tool takes: a split of the claims file, or every participant
#: folder present ("folder": another data folder's people, e.g. held-out participants)
SELECTIONS = ("tuning", "test", "all", "folder")


def select_people(folder: Path, selection: str, dataset: str = "ue_adl", claims: Claims | None = None
                  ) -> tuple[str, ...]:
    """The participants of recording set `folder` (one sub-folder each) a tool uses: "folder" every
    sub-folder present, else the claims file's split (`SELECTIONS`), each of which must be there."""
    if selection not in SELECTIONS:
        raise ClaimsError(f"people must be one of {list(SELECTIONS)}, got {selection!r}")
    present = sorted(p.name for p in Path(folder).iterdir() if p.is_dir() and _NAME.fullmatch(p.name))
    if selection == "folder":
        if not present:
            raise ClaimsError(f"{folder}: holds no participant folders")
        return tuple(present)
    wanted = (claims or load_claims()).people_of(dataset, selection)
    missing = [name for name in wanted if name not in present]
    if missing:
        raise ClaimsError(f"{folder}: the {selection} people {missing} of the claims file are not there "
                          "(another folder's people: select 'folder')")
    return wanted
