"""A failed orbit solve is said in words: numpy's bare "Singular matrix" (what
``cornerbif continue`` printed for a seed whose orbit's Jacobian is singular) names what it
means for the orbit; other failures pass as they are."""

import numpy as np

from cornerbif.continuation import OrbitError, failure_words


def test_a_singular_jacobian_is_said_as_a_fold_or_a_multiplier_at_one():
    try:
        np.linalg.solve(np.zeros((2, 2)), np.ones(2))
    except np.linalg.LinAlgError as e:
        words = failure_words(e)
    assert "Singular matrix" in words and "singular Jacobian" in words
    assert "fold" in words and "multiplier at +1" in words


def test_other_failures_pass_as_they_are():
    assert failure_words(OrbitError("Newton did not converge in 40 steps")) == \
        "Newton did not converge in 40 steps"
