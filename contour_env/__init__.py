"""contour_env: multi-axis CNC feed-drive contouring environments (SI units throughout)."""
