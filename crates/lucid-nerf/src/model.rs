//! The NeRF model as a burn module: the hash table and the MLP weights are burn parameters
//! (so burn's Adam and recorder handle them); evaluation goes through the fused field op.

use burn::module::{Module, Param};
use burn::tensor::{Device, Tensor, TensorData};
use lucid_scene::sampling::Rng;

use crate::field::FieldConfig;
use crate::ops;

/// Parameters of the radiance field.
#[derive(Module, Debug)]
pub struct NerfModel {
    /// Hash-grid feature table (`entries×F`).
    pub table: Param<Tensor<2>>,
    /// All MLP weights, flat, in [`crate::field::FieldLayout`] order.
    pub mlp: Param<Tensor<1>>,
}

impl NerfModel {
    /// Fresh parameters: the table uniform in ±10⁻⁴ (instant-ngp), each MLP matrix
    /// Xavier-uniform. Drawn with our own seeded generator, so every backend starts from the
    /// same numbers.
    pub fn init(config: &FieldConfig, device: &Device, seed: u64) -> Self {
        let layout = config.layout();
        let mut rng = Rng::new(seed, 0x6e65_7266);
        let mut uniform =
            |n: usize, bound: f32| -> Vec<f32> { (0..n).map(|_| (2.0 * rng.uniform() - 1.0) * bound).collect() };
        let table = uniform(layout.grid.entries * layout.grid.features, 1e-4);
        let mut mlp = Vec::with_capacity(layout.mlp_params());
        for shape in [&layout.density, &layout.colour] {
            for l in 0..shape.layers() {
                let (i, o, _) = shape.layer(l);
                mlp.extend(uniform(i * o, (6.0 / (i + o) as f32).sqrt()));
            }
        }
        Self::from_values(config, table, mlp, device)
    }

    /// A model from raw parameter values (e.g. a checkpoint's).
    pub fn from_values(config: &FieldConfig, table: Vec<f32>, mlp: Vec<f32>, device: &Device) -> Self {
        let layout = config.layout();
        let table = Tensor::from_data(TensorData::new(table, [layout.grid.entries, layout.grid.features]), device);
        let mlp = Tensor::from_data(TensorData::new(mlp, [layout.mlp_params()]), device);
        Self { table: Param::from_tensor(table), mlp: Param::from_tensor(mlp) }
    }

    /// A one-entry stand-in, held while the real parameters pass through the optimiser.
    pub(crate) fn stand_in(device: &Device) -> Self {
        let one = |shape: [usize; 2]| Tensor::<2>::from_data(TensorData::new(vec![0.0f32], shape), device);
        Self { table: Param::from_tensor(one([1, 1])), mlp: Param::from_tensor(one([1, 1]).reshape([1])) }
    }

    /// `σ, r, g, b` at normalised positions (`S×3`) with their footprints (`S`, see
    /// [`crate::encoding::hash_grid::HashGridLayout::weigh_by_footprint`]) along unit directions.
    pub fn field(
        &self,
        positions: Tensor<2>,
        footprints: Tensor<1>,
        directions: Tensor<2>,
        config: FieldConfig,
    ) -> Tensor<2> {
        ops::field(positions, footprints, directions, self.table.val(), self.mlp.val(), config)
    }

    /// Density only, never tracked.
    pub fn density(&self, positions: Tensor<2>, footprints: Tensor<1>, config: FieldConfig) -> Tensor<1> {
        ops::field_density(positions, footprints, self.table.val(), self.mlp.val(), config)
    }

    /// Density and the activations that gave it, never tracked: see [`Self::field_from_density`].
    pub fn density_saving(
        &self,
        positions: Tensor<2>,
        footprints: Tensor<1>,
        config: FieldConfig,
    ) -> (Tensor<1>, Tensor<2>) {
        ops::field_density_saving(positions, footprints, self.table.val(), self.mlp.val(), config)
    }

    /// [`Self::field`] from the activations [`Self::density_saving`] gave at the positions
    /// with the current weights.
    pub fn field_from_density(
        &self,
        positions: Tensor<2>,
        footprints: Tensor<1>,
        directions: Tensor<2>,
        density: Tensor<2>,
        config: FieldConfig,
    ) -> Tensor<2> {
        ops::field_from_density(positions, footprints, directions, density, self.table.val(), self.mlp.val(), config)
    }
}
