"""A pick-and-place trial's checkpoint kept in memory, and the stop that stands for a kill:
what the resume tests of the pick-and-place pipeline share."""

import json


class Stop(Exception):
    """Stands for the kill of a trial."""


class MemoryCheckpoint:
    """Keeps the last progress saved (through JSON, as a checkpoint file does); raises Stop at
    the ``stop_after``-th save, once."""

    def __init__(self, stop_after=None):
        self.saved, self.saves, self.stop_after = None, 0, stop_after

    def load(self):
        return self.saved

    def save(self, progress):
        self.saved = json.loads(json.dumps(progress))
        self.saves += 1
        if self.saves == self.stop_after:
            self.stop_after = None
            raise Stop
