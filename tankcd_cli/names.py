"""The names and codes the whole package shares, each defined once: the command line's choices,
the scene schema, the writers and the kernels all take them from here (and importing this module
costs nothing, so ``--help`` stays instant).
"""

# region classes: codes in the stores' class rasters and the poses' region column
FLAT, GENERAL, UNEVEN = 0, 1, 2
CLASS_NAMES = ("flat", "general", "uneven")
NO_CLASS = 255  # no terrain (NODATA), or no class known under a footprint
NO_CLASS_NAME = "unknown"

# matchers (codes in Poses.matcher; see matching.match)
KEY_POINT_MATCHERS = ("two_point", "four_point", "six_point", "wheel_stations")  # cheapest first
MATCHERS = KEY_POINT_MATCHERS + ("reference",)
REFERENCE = 4
MATCHER_CHOICES = MATCHERS + ("auto",)
# what placed a pose: a matcher, or a key-point matcher whose pose failed the reference's
# certificate and was solved again by the reference (ESCALATED + the key-point matcher's code)
ESCALATED = 5
PLACED_BY = MATCHERS + tuple(f"{m}+reference" for m in KEY_POINT_MATCHERS)
NO_MATCHER = "none"  # the matcher column of a row without a pose
# the key-point matcher ``auto`` gives each region class: the most accurate against the reference on
# the generated corpus of terrain families, ties to the one fewest poses fail the certificate with
# (tradeoff.corpus; a test holds the two together)
AUTO_RULE = {"flat": "wheel_stations", "general": "wheel_stations", "uneven": "wheel_stations"}

# pose status (codes in Poses.status, names in the poses' status column)
STATUS = ("ok", "partly_off", "off")
OK, PARTLY_OFF, OFF = 0, 1, 2

# vehicles, terrains, trees
PRESET_NAMES = ("t72", "t55", "m1")
UP_AXES = ("z", "y")
CURVATURE_METHODS = ("cotan", "sphere", "jet")  # on meshes; DEMs also take "grid"
# classify --method auto, by measurement (README "Curvature"): the grid operator on a DEM's posts,
# the jet on an irregular mesh (cotan does not converge there), cotan on a DEM's regular triangles
AUTO_METHODS = {"dem": "grid", "mesh": "jet", "dem_as_mesh": "cotan"}
KDOP_KS = (6, 14, 18, 26)
SPLITS = ("median", "sah")
TREE_DEFAULTS = {"k": 18, "aabb_levels": 2, "split": "sah", "leaf_size": 4}

# exit codes (the command line's; README "Exit codes")
EXIT_DONE, EXIT_COLLISION, EXIT_USAGE, EXIT_BAD_INPUT, EXIT_INTERNAL = 0, 1, 2, 3, 4
