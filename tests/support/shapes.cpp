// shapes: not written yet.
