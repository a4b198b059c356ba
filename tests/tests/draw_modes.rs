//! Every draw pipeline for every attribute set, in every mode, on both backends (issue 11).
//! The lit fill and the check's front pass read only the fragment inputs the model has (one
//! entry point per attribute set, `draw.wgsl`) and pipelines are made when first used, so an
//! entry point whose inputs do not match the vertex stage's outputs would fail only when a
//! frame first asks for it: each combination is drawn here and the device checked after it.
//! The lit fill of a coloured model must show its colours, of a plain one the plain colour;
//! the color mode the same unlit, or `ALBEDO_GREY` on every model pixel.

use tessera_preprocess::{BuildConfig, Construction};
use tessera_runtime::camera::{Camera, Y_UP};
use tessera_runtime::gpu::{
    Backend, FrameRequest, Readback, Renderer, RendererOptions, ShadingMode, ALBEDO_GREY,
};
use tessera_tests::{build, gpu_on};

const SIZE: u32 = 192;

/// Pixels of the model (not the corner's background colour) and, of those, the ones far
/// redder than the plain colour (0.82, 0.80, 0.76) is: the attributed mesh's colours are
/// red-dominant with blue 7/255.
fn model_and_red_pixels(image: &image::RgbaImage) -> (usize, usize) {
    let background = *image.get_pixel(0, 0);
    let model: Vec<_> = image.pixels().filter(|&&p| p != background).collect();
    let red = model
        .iter()
        .filter(|p| p[0] as u32 > 2 * p[2] as u32 + 16)
        .count();
    (model.len(), red)
}

#[test]
fn every_mode_draws_for_every_attribute_set_on_both_backends() {
    for backend in [Backend::Vulkan, Backend::Gl] {
        let ctx = gpu_on(backend);
        for (normals, colours) in [(false, false), (true, false), (false, true), (true, true)] {
            let mut mesh = tessera_tests::attributed_demo_mesh(3);
            if !normals {
                mesh.normals = None;
            }
            if !colours {
                mesh.colors = None;
            }
            let config = BuildConfig {
                construction: Construction::LeafTriangles(64),
                ..Default::default()
            };
            let built = build(&mesh, &config);
            let header = *built.repo.header();
            let camera = Camera {
                width: SIZE,
                height: SIZE,
                ..Camera::orbit(header.bbox_min, header.bbox_max, Y_UP, 30.0, 20.0, 1.6)
            };
            // The indexed draw, and the vertex-pulling one (a page's index region of one slot).
            for index_slots in [None, Some(1)] {
                let options = RendererOptions {
                    width: SIZE,
                    height: SIZE,
                    index_slots,
                    ..Default::default()
                };
                let mut renderer = Renderer::new(&ctx, &built.repo, options).unwrap();
                let modes = [
                    ShadingMode::Lit,
                    ShadingMode::Patches,
                    ShadingMode::Levels,
                    ShadingMode::Check,
                    ShadingMode::CheckUnderside,
                    ShadingMode::Color,
                    ShadingMode::Normals,
                    ShadingMode::NormalsFaces,
                ];
                for mode in modes {
                    for (wireframe, two_sided) in [(false, false), (true, true)] {
                        let what = format!(
                            "{backend:?}, attributes {}, {mode:?}, index slots {index_slots:?}, \
                             wireframe {wireframe}, two-sided {two_sided}",
                            header.attributes
                        );
                        let request = FrameRequest {
                            mode,
                            wireframe,
                            two_sided,
                            ..FrameRequest::new(camera, 1.0)
                        };
                        let readback = Readback {
                            image: true,
                            selection: false,
                        };
                        renderer.render(&ctx, &request, readback);
                        let image = renderer
                            .read_image(&ctx)
                            .unwrap_or_else(|e| panic!("{what}: {e}"));
                        ctx.check().unwrap_or_else(|e| panic!("{what}: {e}"));
                        if mode == ShadingMode::Color && !wireframe {
                            // Unlit: the colours themselves, or the grey.
                            let (model, red) = model_and_red_pixels(&image);
                            assert!(model > 1000, "{what}: {model} model pixels");
                            let grey = image.pixels().filter(|p| p.0 == ALBEDO_GREY).count();
                            if colours {
                                assert!(red * 2 > model, "{what}: {red} of {model} pixels red");
                            } else {
                                assert_eq!(grey, model, "{what}: {grey} of {model} grey");
                            }
                        }
                        if mode != ShadingMode::Lit {
                            continue;
                        }
                        let (model, red) = model_and_red_pixels(&image);
                        assert!(model > 1000, "{what}: {model} model pixels");
                        if colours {
                            assert!(red * 2 > model, "{what}: {red} of {model} pixels red");
                        } else {
                            assert_eq!(red, 0, "{what}: red pixels on a plain model");
                        }
                    }
                }
            }
        }
    }
}
