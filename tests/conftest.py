import os
import sys

import pytest

HERE = os.path.dirname(__file__)
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)


@pytest.fixture
def configs_dir():
    return os.path.join(ROOT, "configs")
