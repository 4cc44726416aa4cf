import pytest

import maniladder_ms


@pytest.fixture(scope="session")
def catalog():
    return maniladder_ms.default_catalog()
