"""Stop a search and go on later: save where it stood, resume, and end as if it never stopped.

A search that stops unfinished (a budget, Ctrl-C) keeps its state in ``res.raw.state``; saved
to a file and loaded back, it is passed as ``resume=``. The resumed search ends with the same
boxes, counts and answer as one that was never stopped.

Run: ``python examples/save_resume.py``.
"""

import tempfile
from pathlib import Path

import kinbox
from kinbox.search.state import SearchState

whole = kinbox.solve("general-6r")  # the general 6R loop: 16 configurations
print(f"in one go: {len(whole.solutions)} solutions, {whole.stats['boxes']} boxes")

part = kinbox.solve("general-6r", max_boxes=40)  # stops after 40 boxes, incomplete
print(f"stopped: complete={part.complete} ({part.message}); {len(part.solutions)} solutions so far")

with tempfile.TemporaryDirectory() as tmp:
    path = Path(tmp) / "6r.npz"
    part.raw.state.save(path)  # what the CLI's --save FILE writes
    state = SearchState.load(path)  # ... later, or in another process (--resume FILE)
    rest = kinbox.solve("general-6r", resume=state)

print(f"resumed: complete={rest.complete}; {len(rest.solutions)} solutions, {rest.stats['boxes']} boxes")
assert rest.complete and len(rest.solutions) == len(whole.solutions)
