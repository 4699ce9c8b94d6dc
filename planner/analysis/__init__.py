"""The map's analysis (gates, tight tunnels, the ``clean`` penalty), goal waves (whole-map
and resumable), the numba kernels, and plans."""
