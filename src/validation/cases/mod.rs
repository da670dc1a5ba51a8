//! Registry of case runners, keyed by the three-digit case id.

use super::case::Runner;

mod brownian;
mod brownian_capture;
mod brownian_chains;
mod brownian_equilibrium;
mod brownian_scenes;
mod common;
mod contact;
mod coupled;
mod dem;
mod dem_figures;
mod dem_packing;
mod dem_zhou;
mod deposition;
mod deposition_figures;
mod drag;
mod elliptic_cases;
mod field_analytic;
mod field_oracle;
mod lbm;
mod lbm_boundaries;
mod lbm_packings;
mod packing;
mod packing_confined;
mod shapes;

/// The runner for case `id` ("104"), if one is registered.
pub fn runner_for(id: &str) -> Option<Runner> {
    match id {
        "001" => Some(elliptic_cases::case_001),
        "002" => Some(shapes::case_002),
        "003" => Some(shapes::case_003),
        "201" => Some(drag::case_201),
        "101" => Some(field_analytic::case_101),
        "102" => Some(field_analytic::case_102),
        "103" => Some(field_analytic::case_103),
        "105" => Some(field_analytic::case_105),
        "106" => Some(field_analytic::case_106),
        "104" => Some(field_oracle::case_104),
        "107" => Some(field_oracle::case_107),
        "108" => Some(field_oracle::case_108),
        "301" => Some(contact::case_301),
        "302" => Some(contact::case_302),
        "303" => Some(contact::case_303),
        "304" => Some(contact::case_304),
        "305" => Some(contact::case_305),
        "601" => Some(deposition::case_601),
        "602" => Some(deposition::case_602),
        "603" => Some(deposition::case_603),
        "604" => Some(deposition::case_604),
        "605" => Some(deposition::case_605),
        "606" => Some(deposition::case_606),
        "607" => Some(deposition::case_607),
        "608" => Some(deposition::case_608),
        "609" => Some(deposition::case_609),
        "901" | "902" => Some(deposition_figures::case_901_902),
        "910" | "914" => Some(deposition_figures::case_910_914),
        "911" => Some(deposition_figures::case_911),
        "912" => Some(deposition_figures::case_912),
        "913" => Some(deposition_figures::case_913),
        "811" => Some(coupled::case_811),
        "812" => Some(coupled::case_812),
        "813" => Some(coupled::case_813),
        "814" => Some(coupled::case_814),
        "815" => Some(coupled::case_815),
        "816" => Some(coupled::case_816),
        "817" => Some(coupled::case_817),
        "840" => Some(coupled::case_840),
        "940" => Some(coupled::case_940),
        "941" => Some(coupled::case_941),
        "501" => Some(packing::case_501),
        "502" => Some(packing::case_502),
        "503" => Some(packing::case_503),
        "504" => Some(packing::case_504),
        "505" => Some(packing::case_505),
        "506" => Some(packing::case_506),
        "507" => Some(packing::case_507),
        "514" => Some(packing::case_514),
        "508" => Some(packing::case_508),
        "509" => Some(packing::case_509),
        "510" => Some(packing::case_510),
        "516" => Some(packing::case_516),
        "517" => Some(packing::case_517),
        "512" => Some(packing::case_512),
        "522" => Some(packing::case_522),
        "513" => Some(packing::case_513),
        "515" => Some(packing_confined::case_515),
        "520" => Some(packing::case_520),
        "521" => Some(packing::case_521),
        "401" => Some(brownian::case_401),
        "402" => Some(brownian::case_402),
        "403" => Some(brownian::case_403),
        "404" => Some(brownian::case_404),
        "405" => Some(brownian::case_405),
        "406" => Some(brownian::case_406),
        "407" => Some(brownian::case_407),
        "408" => Some(brownian::case_408),
        "409" => Some(brownian::case_409),
        "410" => Some(brownian_capture::case_410),
        "411" => Some(brownian_capture::case_411),
        "412" => Some(brownian_capture::case_412),
        "413" => Some(brownian_equilibrium::case_413),
        "414" => Some(brownian_equilibrium::case_414),
        "415" => Some(brownian_scenes::case_415),
        "416" => Some(brownian_scenes::case_416),
        "417" => Some(brownian_scenes::case_417),
        "418" => Some(brownian_scenes::case_418),
        "419" => Some(brownian_scenes::case_419),
        "420" => Some(brownian_chains::case_420),
        "421" => Some(brownian_chains::case_421),
        "422" => Some(brownian_capture::case_422),
        "801" => Some(lbm::case_801),
        "802" => Some(lbm::case_802),
        "803" => Some(lbm::case_803),
        "804" => Some(lbm::case_804),
        "808" => Some(lbm::case_808),
        "805" => Some(lbm_boundaries::case_805),
        "810" => Some(lbm_boundaries::case_810),
        "809" => Some(lbm_boundaries::case_809),
        "806" => Some(lbm::case_806_807),
        "807" => Some(lbm::case_806_807),
        "818" | "819" => Some(lbm::case_818_819),
        "920" => Some(lbm_packings::case_920),
        "921" | "922" => Some(lbm_packings::case_921_922),
        "701" => Some(dem::case_701),
        "702" => Some(dem::case_702),
        "703" => Some(dem::case_703),
        "704" => Some(dem::case_704),
        "705" => Some(dem::case_705),
        "706" => Some(dem::case_706),
        "707" => Some(dem::case_707),
        "708" => Some(dem::case_708),
        "709" => Some(dem::case_709),
        "710" => Some(dem::case_710),
        "711" => Some(dem::case_711),
        "712" => Some(dem::case_711),
        "713" | "714" => Some(dem_zhou::case_713_714),
        "715" => Some(dem_packing::case_715),
        "930" => Some(dem_figures::case_930),
        "931" => Some(dem_figures::case_931),
        "932" => Some(dem_figures::case_932),
        _ => None,
    }
}
