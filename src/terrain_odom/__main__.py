"""``python -m terrain_odom`` runs the command line."""

from terrain_odom.cli.main import main

raise SystemExit(main())
