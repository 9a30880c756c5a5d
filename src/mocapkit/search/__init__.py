"""Fast similarity search in motion databases (Krüger et al. 2010; Tautges 2012, sec. 3.4, 4.3.3).

* :mod:`mocapkit.search.knn` — k-nearest-neighbour index over any feature set
  (kd-tree by default, brute force and FAISS behind the same interface).
* :mod:`mocapkit.search.dtw` — dynamic time warping: classic, subsequence
  (Müller 2007) and the step-size/weight variant of Tautges eq. 4.2; the
  exact reference the graphs are checked against.
* :mod:`mocapkit.search.lng` — the lazy neighbourhood graph (Krüger sec. 4.1)
  and its online variant (Tautges sec. 3.4.3).
* :mod:`mocapkit.search.fatgraph` — fat-graph base poses (Krüger sec. 5.3).

Results of global matching are :class:`Match` records in database frame
indices; :class:`mocapkit.database.MotionDatabase` turns them into clips and
frames.
"""

from .matches import Match

__all__ = ["Match"]
