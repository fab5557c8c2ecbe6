"""Algorithm 2: the oracle subtree.

Criteria split into two groups: ``record`` criteria, and ``period`` + ``final``
criteria (the paper's *others*, which decide when a run is over). Each group is
a Parallel: ``SuccessOnAll`` for ``&&``, ``SuccessOnOne`` for ``||`` (members
wrapped in :class:`~btgen_pytrees.leaves.wiring.OrMember` so the group fails only
when every member has failed). The oracle root is a ``Parallel`` with policy
``SuccessOnSelected([others])``: the others group is the exit condition, while a
failing record group still fails it.

Where the paper has no answer:

* an empty group is left out;
* with no *others* criteria the oracle root is ``SuccessOnAll`` over the record
  group (it never succeeds on its own: records only fail), and the full tree
  uses the execute subtree as its exit condition instead;
* with no criteria at all there is no oracle subtree.
"""

from __future__ import annotations

from typing import Sequence as Seq

import py_trees

from ..leaves import Environment, Registry
from ..leaves.composites import Parallel
from ..leaves.wiring import OrMember
from ..model import Criterion

__all__ = ["oracle_subtree"]

Policy = py_trees.common.ParallelPolicy


def _group(label: str, criteria: Seq[Criterion], relation: str, env: Environment, registry: Registry) -> Parallel:
    leaves = [registry.build(c, env) for c in criteria]
    if relation == "||":
        ids = [c.id for c in criteria]
        members = [OrMember(leaf, env, c.id, ids) for leaf, c in zip(leaves, criteria)]
        return Parallel(f"{label} ||", Policy.SuccessOnOne(), members)
    return Parallel(f"{label} &&", Policy.SuccessOnAll(synchronise=True), leaves)


def oracle_subtree(
    criteria: Seq[Criterion], relation: dict[str, str] | None, env: Environment, registry: Registry
) -> tuple[Parallel | None, Parallel | None]:
    """Build the oracle subtree (Algorithm 2).

    Returns:
        ``(oracle_root, others_group)``; either may be ``None`` (see module notes).
    """
    relation = dict(relation or {})
    records = [c for c in criteria if c.type == "record"]
    others = [c for c in criteria if c.type != "record"]
    record_group = _group("record", records, relation.get("record", "&&"), env, registry) if records else None
    others_group = _group("others", others, relation.get("others", "&&"), env, registry) if others else None
    groups = [g for g in (record_group, others_group) if g is not None]
    if not groups:
        return None, None
    if others_group is not None:
        policy: Policy.Base = Policy.SuccessOnSelected([others_group], synchronise=True)
    else:
        policy = Policy.SuccessOnAll(synchronise=True)
    return Parallel("oracle", policy, groups), others_group
