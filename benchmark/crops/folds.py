"""Scene- and person-disjoint 3x3 cross-validation (Wang et al. 2017, Sec. 5.4).

Persons are split into 3 groups and scenes into 3 groups. Fold ``(i, j)`` tests on the
persons of group ``i`` in the scenes of group ``j`` and trains only on persons outside
group ``i`` in scenes outside group ``j``: no person and no scene is shared between the
training and the test data of a fold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Fold", "make_folds"]


@dataclass(frozen=True)
class Fold:
    i: int
    j: int
    train_persons: frozenset
    train_scenes: frozenset
    test_persons: frozenset
    test_scenes: frozenset

    @property
    def name(self) -> str:
        return f"p{self.i}s{self.j}"


def _groups(ids, n, rng):
    ids = np.array(sorted(set(ids)))
    perm = rng.permutation(len(ids))
    return [frozenset(ids[perm[k::n]].tolist()) for k in range(n)]


def make_folds(person_ids, scene_ids, *, n_groups: int = 3,
               rng: np.random.Generator) -> list[Fold]:
    """The ``n_groups`` x ``n_groups`` person/scene-disjoint folds.

    Raises
    ------
    ValueError
        With fewer than ``n_groups`` distinct persons or scenes (each group needs one).
    """
    persons, scenes = sorted(set(person_ids)), sorted(set(scene_ids))
    need = []
    if len(persons) < n_groups:
        need.append(f"{n_groups} persons (it has {len(persons)})")
    if len(scenes) < n_groups:
        need.append(f"{n_groups} scenes (it has {len(scenes)})")
    if need:
        raise ValueError(f"a {n_groups}x{n_groups} person/scene-disjoint split needs at least "
                         + " and ".join(need))
    pg, sg = _groups(persons, n_groups, rng), _groups(scenes, n_groups, rng)
    allp, alls = frozenset(persons), frozenset(scenes)
    return [Fold(i, j, allp - pg[i], alls - sg[j], pg[i], sg[j])
            for i in range(n_groups) for j in range(n_groups)]
