"""Full-body motion from sparse control signals (Krüger et al. 2010, sec. 5.2; Tautges 2012, chapters 2-4).

* :mod:`~mocapkit.reconstruct.markers`: a few marker trajectories -> full body,
  kNN of the control features, a local linear (PCA) pose model, a smooth fit.
* :mod:`~mocapkit.reconstruct.accelerometers`: four accelerometers -> full body,
  the online lazy neighbourhood graph and the kernel priors of Tautges ch. 3.
* :mod:`~mocapkit.reconstruct.ssg`: gappy marker trajectories -> full body,
  the subsequence graph of Tautges ch. 4.
* :mod:`~mocapkit.reconstruct.multilinear`: HOSVD motion tensors of one motion
  class and their fit to accelerometer readings (Tautges ch. 2).
"""
