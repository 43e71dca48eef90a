"""A predicted region whose front bones cross in it splits into two that overlap at the crossing (three local
layers, ops.segmentation.nesting)."""
import numpy as np

from ops.segmentation.bones import thick_regions
from ops.segmentation.nesting import nest_crossed_fronts
from tests.ops.geometry.test_three_layers import L_FOREARM, R_FOREARM, folded_arms


def test_crossed_forearms_split_into_the_lower_ones_region_and_the_rests():
    refined, sk, pose, _ = folded_arms()
    body = refined.foreground
    region = refined.occlusion[0] | refined.occlusion[1]  # one region, both forearms in front, as predicted
    regions, fronts, groups, notes = nest_crossed_fronts([region], [np.array([L_FOREARM, R_FOREARM])], body, pose,
                                                         sk)
    assert len(regions) == 2 and len(notes) == 1 and "l_elbow-l_hand" in notes[0] and groups == [0, 0]
    lower, rest = regions
    assert fronts[0].tolist() == [R_FOREARM] and fronts[1].tolist() == [L_FOREARM]  # the right one (z -1) lower
    thick = thick_regions(body, pose, sk)
    # the regions cover the region between them, and overlap exactly where both forearms' bodies lie in it
    assert ((lower | rest) == region).all()
    assert ((lower & rest) == (region & thick[L_FOREARM] & thick[R_FOREARM])).all()
    assert (lower & rest)[67, 64] and (lower & rest).sum() >= 40
    # the right forearm's far end is the lower region's only: there nothing covers it but the chest
    assert (lower & ~rest).any() and (rest & ~lower).any()


def test_fronts_that_do_not_cross_over_a_third_body_stay_one_region():
    refined, sk, pose, _ = folded_arms()
    region = refined.occlusion[0] | refined.occlusion[1]
    far = pose.copy()
    far[:, 2] = [0, 0, 5, 5, 5, 6, 6, 6]  # the torso in front of both arms: nothing lies beneath them both
    regions, fronts, groups, notes = nest_crossed_fronts([region], [np.array([L_FOREARM, R_FOREARM])],
                                                         refined.foreground, far, sk)
    assert len(regions) == 1 and notes == [] and (regions[0] == region).all() and groups == [-1]
    # one front bone: nothing to nest
    regions, _, _, notes = nest_crossed_fronts([region], [np.array([L_FOREARM])], refined.foreground, pose, sk)
    assert len(regions) == 1 and notes == []
