"""Every implemented ManiLadder task; importing this registers their env ids.

Each module here holds one task (or one parameterised family) with its scripted solver; all of them
are imported, so a new task module registers itself without an edit here.
"""

import importlib
import pkgutil

for _module in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_module.name}")
