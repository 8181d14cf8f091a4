// gauss_sphere: not written yet.
