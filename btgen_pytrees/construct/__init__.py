"""Construction: Algorithm 1 (:mod:`.execute`), Algorithm 2 (:mod:`.oracle`), the full tree (:mod:`.tree`)."""

from .execute import MAX_DEPTH, execute_subtree
from .oracle import oracle_subtree
from .tree import generate

__all__ = ["MAX_DEPTH", "execute_subtree", "oracle_subtree", "generate"]
