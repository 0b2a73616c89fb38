import os
import sys

import pytest

HERE = os.path.dirname(__file__)
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)


@pytest.fixture
def configs_dir():
    return os.path.join(ROOT, "configs")

# property tests: reproducible examples in CI (a red CI must be reproducible); random locally
from hypothesis import settings as _hsettings  # noqa: E402

_hsettings.register_profile("ci", derandomize=True, deadline=None)
if os.environ.get("CI"):
    _hsettings.load_profile("ci")
