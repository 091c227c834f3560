"""Reference motions for legged robots: a URDF reader (:mod:`~quadsim.robots.urdf`), leg
detection and IK (:mod:`~quadsim.robots.legs`), retargeting an animal's motion at the same
Froude number (:mod:`~quadsim.robots.retarget`) and the files (:mod:`~quadsim.robots.reference`).
``quadsim retarget`` (:mod:`quadsim.cli_retarget`) puts them together."""
