// exact_predicates: not written yet.
