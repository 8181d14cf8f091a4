// sampler: not written yet.
