"""Independent checks of the sagittal model against other engines (e.g. :mod:`.pymunk_engine`)."""
