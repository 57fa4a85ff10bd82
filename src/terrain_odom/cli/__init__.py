"""Command-line interface of terrain-odom (a thin layer over terrain_odom.app.run)."""
