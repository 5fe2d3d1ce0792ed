//! The non-hardware roots the work-precision table measures in the To calculation (the same
//! definitions as `host_sim::to_roots`; the firmware keeps only `HardwareRoots`).

use thermorph::mlx90640::{
    Calibration, DecodeParams, FrameError, HardwareRoots, Image, Roots, SubpageFrame, SubpageInfo,
};

/// `libm::sqrtf`, fourth root as two.
pub struct LibmSqrtf;

impl Roots for LibmSqrtf {
    fn sqrt(x: f32) -> f32 {
        libm::sqrtf(x)
    }
}

/// `libm::powf(x, 0.25)` for the fourth root.
pub struct LibmPowf;

impl Roots for LibmPowf {
    fn sqrt(x: f32) -> f32 {
        libm::sqrtf(x)
    }

    fn root4(x: f32) -> f32 {
        libm::powf(x, 0.25)
    }
}

/// micromath's approximate square root, fourth root as two.
pub struct MicromathSqrt;

impl Roots for MicromathSqrt {
    fn sqrt(x: f32) -> f32 {
        micromath::F32Ext::sqrt(x)
    }
}

/// micromath's approximate `powf(x, 0.25)` for the fourth root.
pub struct MicromathPowf;

impl Roots for MicromathPowf {
    fn sqrt(x: f32) -> f32 {
        micromath::F32Ext::sqrt(x)
    }

    fn root4(x: f32) -> f32 {
        micromath::F32Ext::powf(x, 0.25)
    }
}

/// Decode one subpage into an image with some roots (an `Image::update_with` instance).
pub type UpdateFn =
    fn(&mut Image, &SubpageFrame, &Calibration, &DecodeParams) -> Result<SubpageInfo, FrameError>;

/// The variants, named as `host-sim mtts-wp` reads them; hardware first.
pub const VARIANTS: [(&str, UpdateFn); 5] = [
    ("vsqrt", Image::update_with::<HardwareRoots>),
    ("libm_sqrtf", Image::update_with::<LibmSqrtf>),
    ("libm_powf", Image::update_with::<LibmPowf>),
    ("micromath_sqrt", Image::update_with::<MicromathSqrt>),
    ("micromath_powf", Image::update_with::<MicromathPowf>),
];
