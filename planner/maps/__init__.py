"""Maps in: grids and Moving AI map text, ROS robot maps in meters and their frames."""
