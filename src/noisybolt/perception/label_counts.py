"""How many images show each fluent true, and the refusal of images a classifier could
not learn a spec's fluent from.

:class:`LabelCounts` is a dataset's size and each fluent's positives, saved with a
classifier so that a cached one can be checked again; :func:`check_fluents_shown` refuses
images in which a fluent some spec uses is never true or never false, and warns where it
is true or false in fewer than :data:`RARE_FLUENT_IMAGES` of them.

Example:
    >>> counts = LabelCounts(images=10, positives={"t": 3})
    >>> counts.negatives("t"), counts.to_dict()
    (7, {'images': 10, 'positives': {'t': 3}})
    >>> LabelCounts.from_dict(counts.to_dict(), ["t"]) == counts
    True
"""

from __future__ import annotations

import warnings
from collections.abc import Collection, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

from noisybolt.errors import RareFluentWarning, UnknownFluentError, UnseenFluentError

if TYPE_CHECKING:
    from noisybolt.perception.fluent_dataset import FluentDataset

__all__ = ["RARE_FLUENT_IMAGES", "LabelCounts", "check_fluents_shown", "refuse_unseen"]


class LabelCounts(NamedTuple):
    """How many images a dataset holds and in how many of them each fluent is true.

    A classifier saves them with its ``training`` notes
    (:func:`noisybolt.perception.training.train_classifier`), so that a cached one can be
    checked, when used again, for fluents it never saw true or never saw false.
    """

    images: int
    positives: dict[str, int]

    @classmethod
    def of(cls, dataset: FluentDataset) -> LabelCounts:
        """The counts of ``dataset``."""
        return cls(images=len(dataset), positives=dataset.positives)

    def negatives(self, fluent: str) -> int:
        """Images in which ``fluent`` was false."""
        return self.images - self.positives[fluent]

    def to_dict(self) -> dict[str, Any]:
        """The JSON-able form kept in a classifier's ``training`` notes."""
        return {"images": self.images, "positives": dict(self.positives)}

    @classmethod
    def from_dict(cls, data: Any, fluent_names: Sequence[str]) -> LabelCounts | None:
        """The counts :meth:`to_dict` wrote for ``fluent_names``; None where ``data`` is
        not such a form (absent from a file written before the counts were saved)."""
        if not isinstance(data, dict):
            return None
        images, positives = data.get("images"), data.get("positives")
        if (
            not isinstance(images, int)
            or not isinstance(positives, dict)
            or set(positives) != set(fluent_names)
            or not all(isinstance(n, int) and 0 <= n <= images for n in positives.values())
        ):
            return None
        return cls(images=images, positives={name: positives[name] for name in fluent_names})


#: A fluent some spec uses that is true, or false, in fewer than this many of the images a
#: classifier learns from gets a :class:`~noisybolt.errors.RareFluentWarning`. Why 20: a
#: fifth of them are its validation part (``TrainingConfig.validation_fraction``), so
#: fewer leave about four or fewer there, and the validation table's accuracy and AUROC
#: for the fluent rest on a handful of images; the held-out accuracy that restarts compare
#: counts both values alike, so a classifier that reads 10 positives in 4,000 images all
#: as false still scores 0.9975 on that fluent.
RARE_FLUENT_IMAGES = 20


def check_fluents_shown(
    counts: LabelCounts,
    spec_fluents: Collection[str],
    *,
    source: str,
    what_to_do: str,
    if_rare: str,
) -> None:
    """Refuses images to learn a classifier from in which a fluent some spec uses is never
    true, or never false; warns where it is true or false in only a few of them.

    Args:
        counts: the images and each fluent's positives among them.
        spec_fluents: the fluents the run's specs depend on; no other is checked (a world
            may name fluents its specs do not need).
        source: what the images are, for the messages ("the 4,000 images collected ...").
        what_to_do: the refusal's advice, in the caller's terms (command-line options or
            keyword arguments).
        if_rare: the warning's advice, likewise.

    Raises:
        UnseenFluentError: naming every such fluent, the images and what to do.

    Warns:
        RareFluentWarning: a spec's fluent true, or false, in fewer than
            :data:`RARE_FLUENT_IMAGES` of the images.

    Example:
        >>> counts = LabelCounts(images=800, positives={"has_key": 401, "at_goal": 0})
        >>> advice = {"what_to_do": "Collect more.", "if_rare": "collect more"}
        >>> check_fluents_shown(counts, ["has_key"], source="the images", **advice)
        >>> check_fluents_shown(counts, ["at_goal"], source="the images", **advice)
        Traceback (most recent call last):
        ...
        noisybolt.errors.UnseenFluentError: the images never show 'at_goal' true, and a spec ...
    """
    refuse_unseen(counts, spec_fluents, source=source, what_to_do=what_to_do)
    rare = [
        name
        for name in spec_fluents
        if min(counts.positives[name], counts.negatives(name)) < RARE_FLUENT_IMAGES
    ]
    if rare:
        shown = ", ".join(
            f"{name!r} true in {counts.positives[name]:,} and false in {counts.negatives(name):,}"
            for name in rare
        )
        warnings.warn(
            f"{source} show {shown}: fewer than {RARE_FLUENT_IMAGES} of one value, so the "
            "classifier's accuracy on it rests on a handful of images and the bolt may "
            f"misread it; {if_rare}",
            RareFluentWarning,
            stacklevel=2,
        )


def refuse_unseen(
    counts: LabelCounts, spec_fluents: Collection[str], *, source: str, what_to_do: str
) -> None:
    """The refusal of :func:`check_fluents_shown` alone (no warning), for images collected
    before a classifier is chosen: its warnings wait for the classifier kept."""
    unknown = tuple(name for name in spec_fluents if name not in counts.positives)
    if unknown:
        raise UnknownFluentError(
            f"spec fluent(s) {list(unknown)} are not among the classifier's "
            f"{sorted(counts.positives)}",
            unknown=unknown,
            known=tuple(counts.positives),
        )
    unseen = {
        name: "true" if counts.positives[name] == 0 else "false"
        for name in spec_fluents
        if counts.positives[name] == 0 or counts.negatives(name) == 0
    }
    if not unseen:
        return
    one = len(unseen) == 1
    them, they = ("it", "it holds") if one else ("them", "they hold")
    raise UnseenFluentError(
        f"{source} never show "
        + " or ".join(f"{name!r} {value}" for name, value in unseen.items())
        + f", and a spec uses {them}: the classifier could not learn to tell when {they}, "
        f"so the bolt would read {them} the same whatever the agent does and the spec "
        f"could not steer it. {what_to_do}",
        fluents=tuple(unseen),
        images=counts.images,
    )
