"""The settings of the ``constrained`` scheme's multiplier that depend on the run's kind.

:func:`~noisybolt.runs.resolve` chooses them where a run does not say, from two facts
about the run: whether some spec is kept by an episode without events (its DFA accepts
the empty trace: standing still complies with it, so a price can teach standing still),
and whether the compliance scale is exact (the return gap on a tabular product, the
gridworld's) or a worst case from the world's return bounds. Each choice is measured on
the world where it was made (its docstring); :mod:`noisybolt.bolt.constraint` is the
multiplier they set.
"""

from __future__ import annotations

__all__ = [
    "ANNEAL",
    "KP",
    "LR",
    "WAIT",
    "WINDOW",
    "budget_anneal",
    "full_price_known",
    "price_search",
    "start_price",
]

#: The share of the run over which the budget falls from the first measured cost to the
#: limit (:attr:`CostLimit.anneal`) where a spec is kept by doing nothing: see
#: :func:`budget_anneal`.
ANNEAL = 0.5


def full_price_known(*, exact: bool, kept_by_doing_nothing: bool) -> bool:
    """Whether the compliance scale's full price is known to be just enough and cannot teach
    standing still: the scale is exact (the return gap on a tabular product) and no spec is
    kept by an episode without events. There the budget is the limit from the first rollout
    (:func:`budget_anneal`) and the price starts in full (:func:`start_price`)."""
    return exact and not kept_by_doing_nothing


def budget_anneal(*, exact: bool, kept_by_doing_nothing: bool) -> float:
    """The budget's anneal (:attr:`CostLimit.anneal`) that :func:`~noisybolt.runs.resolve`
    gives a run: 0, the budget at the limit from the first rollout, where no spec is kept
    by an episode without events (its DFA accepts the empty trace) and the scale is exact;
    else :data:`ANNEAL`.

    The anneal guards against the failure the decades guard against: early breaks of a
    spec that standing still keeps (a random policy walks into the lava) priced before
    the task is found teach standing still. Where every spec asks the agent to do
    something, standing still breaks them too, so the price cannot teach it, and an
    annealed budget only delays the price until the direct route has settled, after
    which a detour is no longer found. Measured on the gridworld with
    ``F(top_right_corner) & F(bottom_left_corner)`` (a two-corner detour no suite holds;
    PPO, ground truth, 60k frames, seeds 0-2): with the budget annealed over half the
    run the price reached 0.4 of the scale at 20k frames, by when every seed went
    straight to the goal in 7 steps, and no seed ever complied (compliance 0 % in every
    evaluation); with the budget at the limit from the start (priced in full from the
    first rollout), seeds 1 and 2 complied and reached the goal in every episode from
    40k and 30k frames, and the compliance scheme (priced from the start, no
    multiplier) in all three. But where the scale is a worst case from the world's return
    bounds, the price it reaches at once is no measure of what a detour is worth: on
    CartPole with ``F(left_side)`` (scale 550 from the declared bounds; PPO seed 0, 100k
    frames) the budget at the limit from the start priced the left side in full within
    a few rollouts, and the agent learnt to rush there and drop the pole (return 162,
    compliance 100 %), where annealed it complied and balanced to the end (500, as its
    control). So the budget is at the limit from the start only where the scale is
    exact, the price then just enough (:func:`start_price` alike).

    Example:
        >>> budget_anneal(exact=True, kept_by_doing_nothing=False)
        0.0
        >>> budget_anneal(exact=False, kept_by_doing_nothing=False)
        0.5
        >>> budget_anneal(exact=True, kept_by_doing_nothing=True)
        0.5
    """
    return (
        0.0
        if full_price_known(exact=exact, kept_by_doing_nothing=kept_by_doing_nothing)
        else ANNEAL
    )


def start_price(*, exact: bool, kept_by_doing_nothing: bool, initial: float = 0.0) -> float:
    """The integral the multiplier starts learning from (:attr:`CostLimit.start`) that
    :func:`~noisybolt.runs.resolve` gives a run: 1, the compliance scheme's price, where
    no spec is kept by an episode without events and the scale is exact; else
    ``initial``.

    Where every spec asks for something, a price cannot teach standing still, and the
    agent's first thousands of frames are when a random policy meets the detour most: a
    price that starts low and follows the cost (the proportional term prices a cost of
    0.6 at 0.6) pays less for the detour exactly as the agent begins to take it. Measured
    on the gridworld (PPO, classifier bolt, 60k frames, seed 0) over six liveness detours
    no suite holds, with the budget at the limit from the start: the integral from 0
    (the price 0.76 at 1k frames, 0.81 at 5k while the cost fell to 0.6) complied with 3
    (see ``benchmarks/README.md`` for the count from 1), as the compliance scheme did
    with 5. But the full price is asked at once only where it is known to be just enough:
    an exact scale (the return gap on a tabular product). A scale from the world's return
    bounds is a worst case, and asked in full it drowns the world's reward: CliffWalking's
    ``F(top_row)`` (scale 2,940; PPO seed 0, 300k frames) priced in full from the first
    update complied and stood on the top row to the time limit (goal 0 %, return -100);
    from 0 it complied and reached the goal in every episode (return -17). The first
    rollout is paid at ``initial`` (the multiplier learns from a measured cost), and a
    world whose returns do not differ yet keeps it there (``wait``).

    Example:
        >>> start_price(exact=True, kept_by_doing_nothing=False)
        1.0
        >>> start_price(exact=False, kept_by_doing_nothing=False)
        0.0
        >>> start_price(exact=True, kept_by_doing_nothing=True)
        0.0
    """
    return (
        1.0
        if full_price_known(exact=exact, kept_by_doing_nothing=kept_by_doing_nothing)
        else float(initial)
    )


#: How long the multiplier waits, at most, for the world to pay returns that differ
#: between episodes (a share of the run's frames), where a run does not say: see
#: :attr:`CostLimit.wait`. Measured on FrozenLake 8x8 (``G(!right_col | at_goal)``, PPO
#: seed 2, 100k frames): priced from the first rollout (over three decades), the agent
#: first reached the goal at 70k frames and had lost it again at 100k; the same bolt paid
#: nothing reached it in 75 % of episodes at 20k frames and 100 % from 40k, as the
#: unbolted control of the seed did (95 % at 30k).
WAIT = 0.5


#: The integral gain and the proportional gain where the price is asserted (see
#: :func:`price_search`), and of a multiplier given None (every run saved before
#: :func:`~noisybolt.runs.resolve` chose them by the run's kind).
LR = 0.1
KP = 1.0


#: The fewest frames whose episodes the multiplier pools into one measured cost where the
#: scale is from the world's return bounds (:attr:`CostLimit.window`): the unit of its
#: learning rate, so that the price moves alike whatever a learner's rollout (see
#: :func:`price_search`).
WINDOW = 1000


def price_search(*, exact: bool, kept_by_doing_nothing: bool) -> dict[str, float]:
    """How the multiplier moves (:attr:`CostLimit.lr`, ``kp``, ``release``, ``window``), as
    :func:`~noisybolt.runs.resolve` gives a run where it does not say: *searched* where
    a price could teach standing still (a spec kept by an episode without events, on a
    scale from the world's return bounds), else *asserted* (the second round's gains).
    Either way the price is linear in the multiplier (:attr:`CostLimit.decades` 0).

    Asserted, the proportional term prices a cost above the budget at once (``kp`` 1) and
    the multiplier learns every rollout (from at least :data:`WINDOW` frames where the
    scale is from bounds: below): on the gridworld (an exact scale, the full price
    known to be just enough) that priced four of the spec suite's detours before the
    direct route settled (see :mod:`noisybolt.bolt.constraint`), and where every spec asks
    for something a detour must be priced before the direct route settles: searched, on
    MiniGrid's room with ``F(bottom_left)`` (A2C, 150k frames), seeds 1 and 2 complied in
    50 % and 65 % of episodes where asserted they complied in every one.

    Searched: on a scale from bounds the full price is a worst case, and past some share
    of it a violation costs more than the task is worth: on FrozenLake 8x8 with ``G(!right_col |
    at_goal)`` (scale 1.1, a violation charged and its acceptance taken back: the task's
    one point is outweighed at a price of 0.45) the learner then does best to stand
    still. So the price climbs by the integral alone (``kp`` 0), slowly (``lr`` 0.02: the
    full scale after 50k frames at a cost one above the budget, time for the learner to
    find the compliant variant of a route while the route still pays), falls back as fast
    as it rose where the cost is met (``release`` 1: an agent that met the budget by
    standing still is released to try the task again), and learns from the costs of at
    least :data:`WINDOW` frames (a 40-frame A2C rollout ends one or two episodes, a cost
    of 0 or 1 priced near nothing or near in full at random). Measured (A2C, synthetic
    detector, 300k frames, seeds 0-2, the price then over three decades; the unbolted
    controls reach the goal in 100 %):
    with the second round's gains the agent found the goal by the right column, the
    proportional term priced it in full within a rollout, and seeds 0 and 2 stood still
    to the end (goal 0 %; seed 1 kept the task); with the window alone, the same on
    seeds 0 and 2; with ``kp`` 0 at ``lr`` 0.1, the same; with ``kp`` 0 and ``lr`` 0.02,
    seeds 0 and 1 complied and reached the goal in every episode and seed 2 did not;
    with ``release`` too, the same three outcomes, but seed 2, its price released,
    went back to the goal (by the right column) instead of standing still from 85k
    frames to the end. ``kp`` 1 with ``release`` alone swung the price between 0 and 1
    (goal 0 % on all three).

    The price was spread over three decades on such runs before (a violation first
    priced near 0, a thousandth of the scale a third of the way up), to keep a
    proportional term's first rises from teaching standing still: on CliffWalking
    (``G(!cliff_row)``, scale 2,940) the linear price at ``kp`` 1 stood the agent still, and
    on the lava room (``G(!in_lava)``) too. Searched, the span only delays the price: it
    spends two thirds of its climb under a hundredth of the scale and then passes the
    task's worth in a few thousand frames. Over the world suite's ``G`` specs (30 trials,
    both algorithms, seeds 0-2, 27 whose control did the task), searched over three
    decades 23 kept the task, linear 25: FrozenLake A2C seed 2 complied and reached the
    goal (over three decades it stood still) and Acrobot A2C seed 0 complied in every
    episode (over three decades in 90 %); none was lost (left: FrozenLake PPO seed 1,
    CliffWalking A2C seed 1), and CliffWalking PPO kept the task on both seeds its
    control did. The world suite with these choices: ``benchmarks/README.md``.

    The window pools the episodes of at least :data:`WINDOW` frames into each measured
    cost wherever the scale is from bounds, asserted or searched. Asserted, the
    proportional term prices each measurement's error at once, and a 40-frame A2C rollout
    ends 0 to 3 episodes on MiniGrid's room: each measured cost a 0, a half or a 1, the
    price swinging between its integral and the full scale from one rollout to the next
    (PPO's 1,024-frame rollouts are over the window already: its runs are unchanged).
    Measured on the world suite's A2C trials of specs that ask for something (19 trials,
    each world's budget, seeds 0-2; ``benchmarks/README.md``, "A budget that trades"):
    of those whose control did the task, three kept it that had not (the room's
    ``!right_col U bottom_left`` and ``F(bottom_left)`` seed 2, FrozenLake's
    ``F(bottom_left)`` seed 1), one lost it (the room's ``F(bottom_left)`` seed 1: 65 % /
    80 %, every rollout: 100 % / 100 %), and the rest kept what they had or failed either
    way (the room's ``U`` seeds 0 and 1: the price at the full scale all run and
    the cost never met). On the exact scale (the gridworld) the window is 0 until it is
    measured there: its detours are priced in full from the first rollout, and its
    suites were measured learning every rollout.

    Example:
        >>> price_search(exact=False, kept_by_doing_nothing=True)
        {'kp': 0.0, 'lr': 0.02, 'release': 1.0, 'window': 1000.0}
        >>> price_search(exact=False, kept_by_doing_nothing=False)
        {'kp': 1.0, 'lr': 0.1, 'release': 0.0, 'window': 1000.0}
        >>> price_search(exact=True, kept_by_doing_nothing=True)
        {'kp': 1.0, 'lr': 0.1, 'release': 0.0, 'window': 0.0}
    """
    # Pooled wherever the scale is from bounds; on the exact scale (the gridworld) the
    # window has not been measured yet, and its runs learn every rollout as before.
    window = 0.0 if exact else float(WINDOW)
    if kept_by_doing_nothing and not exact:
        return {"kp": 0.0, "lr": 0.02, "release": 1.0, "window": window}
    return {"kp": KP, "lr": LR, "release": 0.0, "window": window}
