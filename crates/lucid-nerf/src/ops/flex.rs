//! The fused field and the compositing on the flex CPU backend: the slice kernels run on the
//! tensors' own storage.

use burn::backend::Flex;
use burn::backend::flex::FlexTensor;
use burn::tensor::TensorData;

use super::{CompositeArgs, FieldConfig, NerfOps, zeros};
use crate::render::composite::RAY_OUTPUTS;
use lucid_burn::values;

fn tensor<const N: usize>(v: Vec<f32>, shape: [usize; N]) -> FlexTensor {
    FlexTensor::from_data(TensorData::new(v, shape))
}

/// The field's forward on flex storage, from the positions or the density's activations,
/// and the activations the backward needs if `save`.
#[allow(clippy::too_many_arguments)] // the op's tensors and settings, as the trait passes them
fn forward(
    positions: &FlexTensor,
    footprints: &FlexTensor,
    directions: &FlexTensor,
    density: Option<&FlexTensor>,
    table: &FlexTensor,
    mlp: &FlexTensor,
    config: FieldConfig,
    save: bool,
) -> (FlexTensor, Option<FlexTensor>) {
    let layout = config.layout();
    let width = layout.saved_per_sample();
    let dir = values(directions);
    let s = dir.len() / 3;
    let mut out = vec![0.0; 4 * s];
    let mut saved = save.then(|| zeros(s * width));
    match density {
        Some(d) => layout.forward_from_density(&values(d), &dir, &values(mlp), &mut out, saved.as_deref_mut()),
        None => {
            let (pos, foot) = (values(positions), values(footprints));
            layout.forward(&pos, &foot, &dir, &values(table), &values(mlp), &mut out, saved.as_deref_mut())
        }
    }
    (tensor(out, [s, 4]), saved.map(|v| tensor(v, [s, width])))
}

impl NerfOps for Flex {
    fn field_forward(
        positions: FlexTensor,
        footprints: FlexTensor,
        directions: FlexTensor,
        table: FlexTensor,
        mlp: FlexTensor,
        config: FieldConfig,
    ) -> FlexTensor {
        forward(&positions, &footprints, &directions, None, &table, &mlp, config, false).0
    }

    fn field_forward_saving(
        positions: FlexTensor,
        footprints: FlexTensor,
        directions: FlexTensor,
        table: FlexTensor,
        mlp: FlexTensor,
        config: FieldConfig,
    ) -> (FlexTensor, FlexTensor) {
        let (out, saved) = forward(&positions, &footprints, &directions, None, &table, &mlp, config, true);
        (out, saved.expect("saved activations"))
    }

    fn field_from_density(
        positions: FlexTensor,
        footprints: FlexTensor,
        directions: FlexTensor,
        density: FlexTensor,
        table: FlexTensor,
        mlp: FlexTensor,
        config: FieldConfig,
    ) -> FlexTensor {
        forward(&positions, &footprints, &directions, Some(&density), &table, &mlp, config, false).0
    }

    fn field_from_density_saving(
        positions: FlexTensor,
        footprints: FlexTensor,
        directions: FlexTensor,
        density: FlexTensor,
        table: FlexTensor,
        mlp: FlexTensor,
        config: FieldConfig,
    ) -> (FlexTensor, FlexTensor) {
        let (out, saved) = forward(&positions, &footprints, &directions, Some(&density), &table, &mlp, config, true);
        (out, saved.expect("saved activations"))
    }

    fn field_backward(
        positions: FlexTensor,
        footprints: FlexTensor,
        mlp: FlexTensor,
        saved: FlexTensor,
        grad_out: FlexTensor,
        config: FieldConfig,
    ) -> (FlexTensor, FlexTensor) {
        let layout = config.layout();
        let mut gt = zeros(layout.grid.entries * layout.grid.features);
        let mut gm = vec![0.0; layout.mlp_params()];
        let (pos, foot) = (values(&positions), values(&footprints));
        layout.backward(&pos, &foot, &values(&mlp), &values(&saved), &values(&grad_out), &mut gt, &mut gm);
        (tensor(gt, [layout.grid.entries, layout.grid.features]), tensor(gm, [layout.mlp_params()]))
    }

    fn field_density(
        positions: FlexTensor,
        footprints: FlexTensor,
        table: FlexTensor,
        mlp: FlexTensor,
        config: FieldConfig,
    ) -> FlexTensor {
        let pos = values(&positions);
        let mut out = vec![0.0; pos.len() / 3];
        config.layout().density(&pos, &values(&footprints), &values(&table), &values(&mlp), &mut out);
        let n = out.len();
        tensor(out, [n])
    }

    fn field_density_saving(
        positions: FlexTensor,
        footprints: FlexTensor,
        table: FlexTensor,
        mlp: FlexTensor,
        config: FieldConfig,
    ) -> (FlexTensor, FlexTensor) {
        let layout = config.layout();
        let pos = values(&positions);
        let n = pos.len() / 3;
        let (mut out, mut saved) = (vec![0.0; n], zeros(n * layout.density_width()));
        layout.density_saving(&pos, &values(&footprints), &values(&table), &values(&mlp), &mut out, &mut saved);
        (tensor(out, [n]), tensor(saved, [n, layout.density_width()]))
    }

    fn composite(raw: FlexTensor, args: CompositeArgs) -> FlexTensor {
        tensor(args.forward(&values(&raw)), [args.samples.rays(), RAY_OUTPUTS])
    }

    fn composite_grad(raw: FlexTensor, out: FlexTensor, grad_out: FlexTensor, args: CompositeArgs) -> FlexTensor {
        let raw = values(&raw);
        tensor(args.backward(&raw, &values(&out), &values(&grad_out)), [raw.len() / 4, 4])
    }
}
