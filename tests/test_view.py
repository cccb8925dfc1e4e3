"""The plain-data scene description of planner/view.py."""

from __future__ import annotations

import pytest

from planner.view import ActionSteps, BodyState, Keyframes


def test_a_carried_block_stays_in_the_hand_between_keyframes() -> None:
    hand = ("gripper", "tool", (0.0, 0.0, -0.05), (0.0, 0.0, 0.0, 1.0))
    timeline = Keyframes(
        (0.0, 1.0, 2.0),
        (
            {"b1": BodyState((1.0, 0.0, 0.0))},
            {"b1": BodyState(attached=hand)},
            {"b1": BodyState(attached=hand)},
        ),
    )
    assert timeline.at(1.5)["b1"].attached == hand  # carried all the way, not at the origin
    assert timeline.at(0.5)["b1"].attached is None  # still on the table before the pick
    assert timeline.at(0.5)["b1"].position == (1.0, 0.0, 0.0)


def test_a_free_body_moves_in_a_straight_line() -> None:
    timeline = Keyframes(
        (0.0, 2.0), ({"b": BodyState((0.0, 0.0, 0.0))}, {"b": BodyState((2.0, 4.0, 0.0))})
    )
    assert timeline.at(0.5)["b"].position == pytest.approx((0.5, 1.0, 0.0))


def test_action_steps_name_the_action_playing() -> None:
    """A pick takes no time: at the second it starts, the move after it is what plays."""
    steps = ActionSteps((0.0, 4.0, 4.0, 9.0), ("(move a)", "(pick b)", "(move c)", "(place d)"))
    assert steps.at(0.0) == (0, "(move a)")
    assert steps.at(3.9) == (0, "(move a)")
    assert steps.at(4.0) == (2, "(move c)")
    assert steps.at(20.0) == (3, "(place d)")
    assert ActionSteps((), ()).at(1.0) is None
    with pytest.raises(ValueError, match="must not decrease"):
        ActionSteps((1.0, 0.0), ("a", "b"))
