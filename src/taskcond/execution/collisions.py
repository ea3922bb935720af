"""Which contacts Alg. 2 treats as collisions (paper §III-E, Alg. 2 lines 2, 8 and 9).

Alg. 2 compares the contacts after every control step (``currentColl``) with the task condition's allowed
collisions (``taskColl``). :class:`CollisionMonitor` holds that comparison for one execution of a primitive:
a contact is an *unallowed collision* when it involves a moving gripper (or, while the gripper is closed,
the object it held at the start), was not there when the primitive began, is not allowed by the condition
and is not the arrival that a post-condition implies.

Beyond the paper's literal set of allowed pairs:

* a condition speaks of *the* gripper; a skill that moves several arms together (the dual-arm fold)
  allows each collision of ``gripper`` for each of its arms' grippers (:func:`allowed_for_arms`);
* a contact that a post-condition implies is not a collision (:func:`landings`): ``bowl inside bottom
  drawer`` ends with the bowl on the drawer's floor, ``mug above table`` with the mug on the table's top,
  so the held object's contact with that reference in its lower half (inside) or upper half (above) is the
  object arriving, while its contact with a rim (the box's upper half) is still one;
* a gripper's contact with a container that it, or the object it holds, is inside when the primitive
  starts (releasing the toothpaste in the mug opens the fingers against the mug's wall) is allowed: it can
  only leave that container, and moving the goal towards the wall would squeeze what it has just let go;
* a gripper's contact with an object that lies on an object the condition lets it touch, at the
  primitive's start, is allowed (:func:`riders`): folding the cloth lays its top layer, and the Kinova's
  fingers holding it, over the spatula lying on the cloth; moving the goal away from the spatula would
  fold the cloth short of its edge;
* a pair of bodies adjusts the goal once per rollout (:meth:`CollisionMonitor.adjusted`): a contact away
  from the goal (a rim crossed on the way) recurs after every back-up, and moving the goal again each time
  would carry it away.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from taskcond.conditions import GRIPPER, Collision, Relation, SpatialRelation, TaskCondition, is_gripper
from taskcond.execution.world import Observation, Touch


@dataclass(frozen=True)
class Landing:
    """Where a held object's contact with the reference of a post-condition is that post-condition coming
    true (module doc).

    Attributes:
        on_top: ``X above Y`` (the contact lies on Y's top, above :attr:`height`); else ``X inside Y``
            (on Y's floor, below it).
        height: Y's perceived centre, m, world z.
    """

    on_top: bool
    height: float

    def admits(self, touch: Touch) -> bool:
        """``touch`` (between X and Y) lies on the side of :attr:`height` that the relation implies."""
        return bool(touch.position[2] >= self.height) == self.on_top


def landings(cond: TaskCondition, obs: Observation) -> dict[Collision, Landing]:
    """The contacts that ``cond``'s post-conditions ``X inside Y`` and ``X above Y`` between two objects
    imply, by pair X–Y, with Y's perceived centre from ``obs``."""
    out: dict[Collision, Landing] = {}
    for q in cond.post_conditions:
        if not isinstance(q, SpatialRelation) or q.relation not in (Relation.INSIDE, Relation.ABOVE):
            continue
        center = obs.centers.get(q.reference)
        if center is None or is_gripper(q.subject) or is_gripper(q.reference):
            continue
        out[Collision(q.subject, q.reference)] = Landing(q.relation == Relation.ABOVE, float(center[2]))
    return out


def allowed_for_arms(collisions: Sequence[Collision], arms: Sequence[str]) -> set[Collision]:
    """The allowed ``collisions`` of a condition for a skill that moves ``arms`` together: a condition
    speaks of *the* gripper (``gripper and cloth``), and a multi-arm skill (the dual-arm fold, our addition
    to the paper's §IV) performs the primitive with each of its arms, so every such pair is allowed for
    each arm's gripper."""
    allowed = set(collisions)
    for c in collisions:
        for g in arms:
            if c.a == GRIPPER:
                allowed.add(Collision(g, c.b))
            if c.b == GRIPPER:
                allowed.add(Collision(c.a, g))
    return allowed


def containers_left(obs: Observation, arms: Sequence[str]) -> set[Collision]:
    """Contacts of each of ``arms``' grippers with a container that the gripper, or the object it holds,
    is inside in ``obs`` (module doc)."""
    return {
        Collision(g, q.reference)
        for q in obs.predicates
        if isinstance(q, SpatialRelation) and q.relation == Relation.INSIDE
        for g in arms
        if q.subject in (g, obs.grasped(g))
    }


def riders(cond: TaskCondition, obs: Observation, arms: Sequence[str]) -> set[Collision]:
    """Contacts of each of ``arms``' grippers with an object that lies on (``X above Y`` in ``obs``) an
    object Y which ``cond`` allows the gripper to touch (module doc)."""
    handled = {c.b if is_gripper(c.a) else c.a for c in cond.collisions if is_gripper(c.a) != is_gripper(c.b)}
    return {
        Collision(g, q.subject)
        for q in obs.predicates
        if isinstance(q, SpatialRelation)
        and q.relation == Relation.ABOVE
        and q.reference in handled
        and not is_gripper(q.subject)
        for g in arms
    }


@dataclass
class CollisionMonitor:
    """Alg. 2's ``currentColl not in taskColl`` (lines 8–9) for one execution of a primitive.

    Attributes:
        held: objects the moving arms grasp at the start; while the gripper is closed their contacts are the
            arm's own.
        seen: contacts there at the start, and those the goal was already adjusted for.
        allowed: the condition's allowed collisions for the moving arms, the containers being left and what
            lies on what the gripper may touch.
        arrivals: the landings the post-conditions imply, by pair.
    """

    held: set[str]
    seen: set[Collision]
    allowed: set[Collision]
    arrivals: dict[Collision, Landing]

    @classmethod
    def start(cls, cond: TaskCondition, obs: Observation, arms: Sequence[str]) -> CollisionMonitor:
        """The monitor of ``cond`` for a skill moving ``arms``, from the observation ``obs`` at its start."""
        return cls(
            held={o for g in arms if (o := obs.grasped(g)) is not None},
            seen={t.collision for t in obs.touches},
            allowed=allowed_for_arms(cond.collisions, arms)
            | containers_left(obs, arms)
            | riders(cond, obs, arms),
            arrivals=landings(cond, obs),
        )

    def unallowed(self, touches: Sequence[Touch], closed: bool) -> Touch | None:
        """The first of ``touches`` that is an unallowed collision (module doc); ``closed``: the gripper
        command of the piece is closed, so the held objects move with the arm."""
        for touch in touches:
            movers = is_gripper(touch.a) or is_gripper(touch.b)
            if closed:
                movers = movers or touch.a in self.held or touch.b in self.held
            if not movers or touch.collision in self.seen or touch.collision in self.allowed:
                continue
            landing = self.arrivals.get(touch.collision)
            if landing is not None and landing.admits(touch):
                continue
            return touch
        return None

    def adjusted(self, touch: Touch) -> None:
        """The goal was moved for ``touch``: its pair adjusts no more in this execution."""
        self.seen.add(touch.collision)


__all__ = ["CollisionMonitor", "Landing", "allowed_for_arms", "containers_left", "landings", "riders"]
