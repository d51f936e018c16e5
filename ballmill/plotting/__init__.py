"""ballmill.plotting: drawings shared by the scenario reports and the studies (``shell``:
the contact point on the chamber's sphere)."""
